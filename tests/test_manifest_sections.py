"""The manifest read by section (issue 35, item 2): one reader per table, in one registry.

A new table is one module: a reader registered with ``register_section`` is read by
``load_study`` (its key allowed at the top level, its value in ``Study.sections``), with its
errors one line naming the key, and the tables the study always had are the registry's.
"""

import pytest

from inertiafit.errors import InputError
from inertiafit.io import load_study
from inertiafit.io.manifest import TOP_KEYS, top_keys
from inertiafit.io.sections import SECTIONS, Section, register_section
from inertiafit.io.sections.base import as_table, fail, number

RIGID = """\
[bodies.attachment]
prior = "biodex-elbow-attachment"

[[trials]]
file = "a.csv"
bodies = ["attachment"]
kind = "quasi-static"
"""


def test_the_registry_holds_the_tables_in_reading_order():
    # the study's tables, in this order among any others a recipe registers
    shipped = ["bodies", "calibration", "passive", "postures", "emg", "subject", "defaults",
               "trials"]  # fmt: skip
    assert [name for name in SECTIONS if name in shipped] == shipped
    assert set(SECTIONS) <= set(TOP_KEYS)
    for name, section in SECTIONS.items():
        module = section.read.__module__
        home = "trials" if name == "defaults" else name  # [defaults] is the trials' settings
        assert module == f"inertiafit.io.sections.{home}", module


def test_a_table_has_one_reader():
    with pytest.raises(ValueError, match=r"section \[emg\] has a reader already"):
        register_section(Section("emg", lambda value, ctx: None))


def test_the_study_keeps_every_section(tmp_path):
    (tmp_path / "a.csv").write_text("time,angle,velocity,torque\n")
    study = load_study(_manifest(tmp_path, "[calibration]\ntorque_gain_sd = 0.01\n" + RIGID))
    assert study.sections["bodies"] is study.bodies
    assert list(study.bodies) == ["attachment"]
    assert study.sections["calibration"] is study.calibration
    assert study.calibration.torque_gain_sd == 0.01
    assert study.sections["passive"] is None
    assert study.sections["postures"] == {}
    assert study.sections["emg"] is None
    assert study.sections["subject"] is None
    assert study.sections["trials"] is study.trials
    assert study.sections["defaults"] == {}


def _manifest(folder, text):
    path = folder / "study.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_a_new_section_is_one_registration(tmp_path, monkeypatch):
    # a toy [room] table (the temperature the trials were recorded at): registered, it is
    # read with the others; before (negative control), it is an unknown top-level key
    (tmp_path / "a.csv").write_text("time,angle,velocity,torque\n")
    manifest = _manifest(tmp_path, "[room]\ntemperature = 21.5\n" + RIGID)
    with pytest.raises(InputError, match=r"study\.toml: room: unknown top-level key"):
        load_study(manifest)

    def read_room(value, ctx):
        if value is None:
            return None
        table = as_table(value, where=f"{ctx.where}: room", what="temperature = deg C")
        for key in table:
            if key != "temperature":
                raise fail(f"{ctx.where}: room.{key}", "unknown key (allowed: temperature)")
        where = f"{ctx.where}: room.temperature"
        return number(table["temperature"], where=where, what="a temperature in deg C")

    monkeypatch.setitem(SECTIONS, "room", Section("room", read_room, order=50))
    assert "room" in top_keys()
    assert load_study(manifest).sections["room"] == 21.5
    bad = _manifest(tmp_path, '[room]\ntemperature = "warm"\n' + RIGID)
    with pytest.raises(InputError, match=r"study\.toml: room\.temperature: expected a "):
        load_study(bad)
