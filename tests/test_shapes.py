"""Ideal bodies: textbook formulas, axis conventions by direct integration, the paper's tables."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from inertiafit import physics
from inertiafit.errors import InputError
from inertiafit.shapes import (
    SHAPES,
    IdealBody,
    box,
    ideal_body,
    rectangular_tube,
    rod,
    solid_cylinder,
    solid_disk,
    sphere,
    square_tube,
)

# Son et al., Table 2 (attachment, a square tube) and Table 3 (3 kg weight, a solid disk):
# geometry and mass are the starred inputs; rho, x and I the printed ideal values.
TUBE = {"outer": 0.03, "inner": 0.026, "length": 0.45, "mass": 2.91}
DISK = {"radius": 0.05, "thickness": 0.06, "mass": 2.92, "com_distance": 0.45}


# --- textbook formulas --------------------------------------------------------------------------


def test_thin_rod_about_centre_and_end():
    m, length = 1.5, 0.8
    centred = rod(length, mass=m, com_distance=0.0)
    assert centred.inertia_about_com == pytest.approx(m * length**2 / 12, rel=1e-12)
    assert centred.inertia == pytest.approx(0.08, rel=1e-12)  # 1.5 * 0.64 / 12
    from_shaft = rod(length, mass=m)  # starts at the shaft: x = L/2
    assert from_shaft.com_distance == pytest.approx(0.4)
    assert from_shaft.inertia == pytest.approx(m * length**2 / 3, rel=1e-12)
    assert from_shaft.inertia == pytest.approx(0.32, rel=1e-12)


def test_solid_disk_along_and_across():
    m, r, h = 2.0, 0.1, 0.3
    along = solid_disk(r, h, mass=m, com_distance=0.0)
    assert along.inertia_about_com == pytest.approx(m * r**2 / 2, rel=1e-12)  # 0.01
    assert along.inertia_about_com == pytest.approx(0.01, rel=1e-12)
    across = solid_disk(r, h, mass=m, com_distance=0.0, axis="across")
    assert across.inertia_about_com == pytest.approx(m / 12 * (3 * r**2 + h**2), rel=1e-12)
    assert across.inertia_about_com == pytest.approx(0.02, rel=1e-12)  # (0.03 + 0.09) / 6
    # A thin disk across is half its along value (perpendicular-axis theorem).
    thin = solid_disk(r, 1e-6, mass=m, com_distance=0.0, axis="across")
    assert thin.inertia_about_com == pytest.approx(along.inertia_about_com / 2, rel=1e-9)


def test_solid_cylinder_is_the_disk():
    assert solid_cylinder(0.05, 0.2, mass=1.0, com_distance=0.3, axis="across") == solid_disk(
        0.05, 0.2, mass=1.0, com_distance=0.3, axis="across"
    )


def test_sphere():
    body = sphere(0.1, mass=5.0, com_distance=0.0)
    assert body.inertia_about_com == pytest.approx(0.4 * 5.0 * 0.01, rel=1e-12)
    assert body.inertia_about_com == pytest.approx(0.02, rel=1e-12)


def test_box_uses_the_edges_in_the_plane_of_rotation():
    m, a, b, c = 3.0, 0.5, 0.4, 0.2
    body = box(a, b, c, mass=m)
    assert body.inertia_about_com == pytest.approx(m / 12 * (b**2 + c**2), rel=1e-12)
    assert body.inertia_about_com == pytest.approx(0.05, rel=1e-12)
    assert body.com_distance == pytest.approx(b / 2)  # starts at the shaft
    # The edge along the shaft does not enter rho.
    assert box(5 * a, b, c, mass=m).radius_of_gyration == pytest.approx(body.radius_of_gyration)


def test_square_tube_is_the_difference_of_two_cuboids():
    outer, inner, length, density = 0.03, 0.026, 0.45, 7850.0
    tube = square_tube(outer, inner, length, density=density, com_distance=0.0)
    # Solid A x A and a x a cuboids, edge ``a`` of box() along the shaft, ``b`` along the arm.
    full = box(outer, length, outer, density=density, com_distance=0.0)
    core = box(inner, length, inner, density=density, com_distance=0.0)
    assert tube.mass == pytest.approx(full.mass - core.mass, rel=1e-12)
    assert tube.inertia_about_com == pytest.approx(
        full.inertia_about_com - core.inertia_about_com, rel=1e-12
    )
    # Independently by hand: rho² = (A² + a² + l²)/12.
    assert tube.radius_of_gyration**2 == pytest.approx(
        (outer**2 + inner**2 + length**2) / 12, rel=1e-12
    )


def test_rectangular_tube_is_the_difference_of_two_cuboids():
    big_w, big_h, small_w, small_h, length, density = 0.08, 0.05, 0.06, 0.03, 0.3, 2700.0
    tube = rectangular_tube(big_w, big_h, small_w, small_h, length, density=density)
    # The _h sides are parallel to the shaft: box(a = h, b = length, c = w).
    full = box(big_h, length, big_w, density=density)
    core = box(small_h, length, small_w, density=density)
    assert tube.mass == pytest.approx(full.mass - core.mass, rel=1e-12)
    assert tube.inertia_about_com == pytest.approx(
        full.inertia_about_com - core.inertia_about_com, rel=1e-12
    )
    assert tube.com_distance == pytest.approx(length / 2)
    # Turned a quarter turn about its length it is a different body.
    turned = rectangular_tube(big_h, big_w, small_h, small_w, length, density=density)
    assert turned.mass == pytest.approx(tube.mass, rel=1e-12)
    assert abs(turned.radius_of_gyration / tube.radius_of_gyration - 1) > 1e-3


def test_square_tube_equals_rectangular_tube_with_equal_sides():
    square = square_tube(0.04, 0.03, 0.5, mass=2.0, com_distance=0.3)
    rect = rectangular_tube(0.04, 0.04, 0.03, 0.03, 0.5, mass=2.0, com_distance=0.3)
    assert square.radius_of_gyration == pytest.approx(rect.radius_of_gyration, rel=1e-12)
    assert square.inertia == pytest.approx(rect.inertia, rel=1e-12)


ALL_BODIES = [
    pytest.param(rod(0.7, mass=1.2, com_distance=0.5), id="rod"),
    pytest.param(solid_disk(0.05, 0.06, mass=2.92, com_distance=0.45), id="disk-along"),
    pytest.param(solid_disk(0.05, 0.2, density=7800.0, com_distance=0.3, axis="across"), id="cyl"),
    pytest.param(square_tube(0.03, 0.026, 0.45, mass=2.91), id="square-tube"),
    pytest.param(rectangular_tube(0.05, 0.03, 0.04, 0.02, 0.4, density=2700.0), id="rect-tube"),
    pytest.param(box(0.1, 0.3, 0.05, mass=4.0, com_distance=0.2), id="box"),
    pytest.param(sphere(0.06, density=1000.0, com_distance=0.35), id="sphere"),
]


@pytest.mark.parametrize("body", ALL_BODIES)
def test_parallel_axis_theorem(body):
    x = body.com_distance
    assert body.inertia == pytest.approx(body.inertia_about_com + body.mass * x**2, rel=1e-12)
    expected = physics.inertia(body.mass, body.radius_of_gyration, x)
    assert body.inertia == pytest.approx(float(expected), rel=1e-12)
    # Moving the body out by 0.1 m adds m (2 x 0.1 + 0.01) and nothing else.
    moved = dataclasses.replace(body, com_distance=x + 0.1)
    assert moved.inertia - body.inertia == pytest.approx(body.mass * (0.2 * x + 0.01), rel=1e-9)


# --- axis conventions, by integrating r² over a grid ----------------------------------------------
#
# Frame: shaft along z, lever arm along x, y across. rho² about the centroidal axis parallel to
# the shaft is the volume average of x² + y² over the body; a midpoint grid computes it without
# any of the formulas above.


def _grid_rho2(inside, half, n=120):
    axes = [(np.arange(n) + 0.5) / n * 2 * h - h for h in half]
    x, y, z = np.meshgrid(*axes, indexing="ij", sparse=True)
    mask = np.broadcast_to(inside(x, y, z), (n, n, n))
    r2 = np.broadcast_to(x**2 + y**2, (n, n, n))
    cell = np.prod([2 * h / n for h in half])
    return float(r2[mask].mean()), float(mask.sum() * cell)


def _tube_inside(big_w, big_h, small_w, small_h):
    def inside(x, y, z):
        outer = (np.abs(y) <= big_w / 2) & (np.abs(z) <= big_h / 2)
        core = (np.abs(y) < small_w / 2) & (np.abs(z) < small_h / 2)
        return outer & ~core & np.ones_like(x, dtype=bool)

    return inside


GRID_CASES = [
    pytest.param(
        solid_disk(0.05, 0.06, mass=1.0, com_distance=0.0),
        lambda x, y, z: (x**2 + y**2 <= 0.05**2) & (np.abs(z) <= 0.03),
        (0.05, 0.05, 0.03),
        id="disk-along",
    ),
    pytest.param(
        solid_disk(0.05, 0.16, mass=1.0, com_distance=0.0, axis="across"),
        lambda x, y, z: (x**2 + z**2 <= 0.05**2) & (np.abs(y) <= 0.08),
        (0.05, 0.08, 0.05),
        id="disk-across",
    ),
    pytest.param(
        sphere(0.05, mass=1.0, com_distance=0.0),
        lambda x, y, z: x**2 + y**2 + z**2 <= 0.05**2,
        (0.05, 0.05, 0.05),
        id="sphere",
    ),
    pytest.param(
        box(0.3, 0.2, 0.1, mass=1.0),
        lambda x, y, z: np.ones(np.broadcast_shapes(x.shape, y.shape, z.shape), dtype=bool),
        (0.1, 0.05, 0.15),
        id="box",
    ),
    pytest.param(
        rectangular_tube(0.06, 0.12, 0.03, 0.06, 0.15, mass=1.0),
        _tube_inside(0.06, 0.12, 0.03, 0.06),
        (0.075, 0.03, 0.06),
        id="rect-tube",
    ),
]


@pytest.mark.parametrize(("body", "inside", "half"), GRID_CASES)
def test_axis_convention_by_integration(body, inside, half):
    rho2, volume = _grid_rho2(inside, half)
    assert body.radius_of_gyration**2 == pytest.approx(rho2, rel=5e-3)
    if body.volume is not None:
        assert body.volume == pytest.approx(volume, rel=5e-3)


def test_integration_tells_the_tube_orientations_apart():
    # Negative control: the tube with _w and _h swapped misses the grid value by far more than
    # the tolerance above, so that test would catch the wrong side being parallel to the shaft.
    rho2, _ = _grid_rho2(_tube_inside(0.06, 0.12, 0.03, 0.06), (0.075, 0.03, 0.06))
    wrong = rectangular_tube(0.12, 0.06, 0.06, 0.03, 0.15, mass=1.0)
    assert abs(wrong.radius_of_gyration**2 / rho2 - 1) > 0.05


# --- the paper's Tables 1-3 ------------------------------------------------------------------------


def test_paper_table2_ideal_attachment():
    tube = square_tube(TUBE["outer"], TUBE["inner"], TUBE["length"], mass=TUBE["mass"])
    assert tube.com_distance == pytest.approx(0.225, abs=1e-12)
    assert tube.radius_of_gyration == pytest.approx(0.130, abs=5e-4)  # 0.13040
    assert tube.inertia == pytest.approx(0.197, abs=5e-4)  # 0.19681
    # The length dominates: a solid 0.03 m bar also rounds to rho 0.130 and I 0.197, so the
    # printed numbers cannot check the section; the cuboid-difference test above does.
    solid = box(0.03, 0.45, 0.03, mass=TUBE["mass"])
    assert solid.radius_of_gyration == pytest.approx(0.130, abs=5e-4)


def test_paper_table3_ideal_disk():
    disk = solid_disk(0.05, 0.06, mass=2.92, com_distance=0.45)
    assert disk.radius_of_gyration == pytest.approx(0.035, abs=6e-4)  # r / sqrt 2 = 0.03536
    assert disk.radius_of_gyration == pytest.approx(0.05 / math.sqrt(2), rel=1e-12)
    assert disk.inertia == pytest.approx(0.595, abs=5e-4)  # 0.59495
    # Across the shaft rho would print as 0.030 (its I, 0.594, would still round close).
    across = solid_disk(0.05, 0.06, mass=2.92, com_distance=0.45, axis="across")
    assert across.radius_of_gyration == pytest.approx(0.0304, abs=1e-4)
    assert abs(across.radius_of_gyration - 0.035) > 6e-4


def test_density_is_mass_over_volume_and_round_trips():
    volume = (TUBE["outer"] ** 2 - TUBE["inner"] ** 2) * TUBE["length"]  # 1.008e-4 m^3
    assert volume == pytest.approx(1.008e-4, rel=1e-12)
    by_mass = square_tube(TUBE["outer"], TUBE["inner"], TUBE["length"], mass=TUBE["mass"])
    assert by_mass.volume == pytest.approx(volume, rel=1e-12)
    assert by_mass.density == pytest.approx(TUBE["mass"] / volume, rel=1e-12)  # 28 869 kg/m^3
    by_density = square_tube(
        TUBE["outer"], TUBE["inner"], TUBE["length"], density=TUBE["mass"] / volume
    )
    assert by_density.mass == pytest.approx(TUBE["mass"], rel=1e-12)
    assert by_density.inertia == pytest.approx(by_mass.inertia, rel=1e-12)
    assert by_density.inertia == pytest.approx(0.197, abs=5e-4)


def test_paper_table1_density_as_printed_is_wildly_off():
    # Table 1 prints d = (A² l − a² l) / m, a volume per mass. As a density it gives a tube of
    # ~3.5e-9 kg and an inertia eight orders of magnitude below Table 2's 0.197.
    a_out, a_in, length, m = TUBE["outer"], TUBE["inner"], TUBE["length"], TUBE["mass"]
    volume = (a_out**2 - a_in**2) * length
    printed = square_tube(a_out, a_in, length, density=volume / m)
    assert printed.mass / m < 1e-8
    assert printed.inertia < 1e-8

    def table1_inertia_about_com(d):
        # Table 1's formula as printed, with the density d (kg/m^3) it is given.
        outer = d * a_out**2 * length * (a_out**2 + length**2) / 12
        return outer - d * a_in**2 * length * (a_in**2 + length**2) / 12

    tube = square_tube(a_out, a_in, length, mass=m)
    assert table1_inertia_about_com(m / volume) == pytest.approx(tube.inertia_about_com, rel=1e-12)
    assert table1_inertia_about_com(m / volume) + m * 0.225**2 == pytest.approx(0.197, abs=5e-4)
    assert table1_inertia_about_com(volume / m) < 1e-10  # vs 0.0495 kg m^2


# --- the result object ----------------------------------------------------------------------------


def test_gravity_moment_and_as_dict():
    disk = solid_disk(0.05, 0.06, mass=2.92, com_distance=0.45)
    assert disk.gravity_moment() == pytest.approx(2.92 * 9.81 * 0.45, rel=1e-12)  # 12.890
    assert disk.gravity_moment(gravity=9.80665) == pytest.approx(2.92 * 9.80665 * 0.45)
    values = disk.as_dict()
    assert list(values) == [*physics.PARAMETERS, *physics.DERIVED]
    assert values["inertia"] == pytest.approx(0.59495, rel=1e-12)
    assert values["gravity_moment"] == pytest.approx(12.89034, rel=1e-12)
    assert all(isinstance(v, float) for v in values.values())


def test_describe_states_shape_axis_and_numbers():
    text = square_tube(0.03, 0.026, 0.45, mass=2.91).describe()
    assert text.startswith("square-tube (outer 0.03 m, inner 0.026 m, length 0.45 m)")
    assert "perpendicular to the tube" in text
    assert "rho = 0.1304 m" in text
    assert "0.1968 kg m^2" in text
    assert "28869 kg/m^3" in text
    assert "rho = 0.5 m" in IdealBody(1.0, 0.0, 0.5).describe()


def test_ideal_body_is_frozen_and_checked():
    body = IdealBody(2.0, 0.3, 0.1)
    assert body.inertia == pytest.approx(2.0 * (0.01 + 0.09))
    with pytest.raises(dataclasses.FrozenInstanceError):
        body.mass = 3.0  # type: ignore[misc]
    with pytest.raises(InputError, match=r"^IdealBody: mass: must be positive"):
        IdealBody(0.0, 0.3, 0.1)
    with pytest.raises(InputError, match=r"^IdealBody: radius_of_gyration: must not be negative"):
        IdealBody(1.0, 0.3, -0.1)


# --- manifest tables ------------------------------------------------------------------------------

WHERE = "study.toml: bodies.weight.ideal"


@pytest.mark.parametrize(
    ("spec", "direct"),
    [
        (
            {"shape": "solid-disk", "axis": "along", **DISK},
            solid_disk(0.05, 0.06, mass=2.92, com_distance=0.45, axis="along"),
        ),
        (
            {"shape": "solid-cylinder", "radius": 0.05, "thickness": 0.2, "density": 7800.0}
            | {"com_distance": 0.3, "axis": "across"},
            solid_disk(0.05, 0.2, density=7800.0, com_distance=0.3, axis="across"),
        ),
        ({"shape": "rod", "length": 0.7, "mass": 1.2}, rod(0.7, mass=1.2)),
        ({"shape": "square-tube", **TUBE}, square_tube(0.03, 0.026, 0.45, mass=2.91)),
        (
            {"shape": "rectangular-tube", "outer_w": 0.05, "outer_h": 0.03, "inner_w": 0.04}
            | {"inner_h": 0.02, "length": 0.4, "density": 2700.0, "com_distance": 0.25},
            rectangular_tube(0.05, 0.03, 0.04, 0.02, 0.4, density=2700.0, com_distance=0.25),
        ),
        ({"shape": "box", "a": 0.1, "b": 0.3, "c": 0.05, "mass": 4}, box(0.1, 0.3, 0.05, mass=4)),
        (
            {"shape": "sphere", "radius": 0.06, "mass": 1.0, "com_distance": 0.35},
            sphere(0.06, mass=1.0, com_distance=0.35),
        ),
    ],
    ids=lambda v: v["shape"] if isinstance(v, dict) else "",
)
def test_ideal_body_matches_the_constructors(spec, direct):
    assert ideal_body(spec, WHERE) == direct


def test_ideal_body_paper_weight():
    body = ideal_body(
        {
            "shape": "solid-disk",
            "radius": 0.05,
            "thickness": 0.06,
            "mass": 2.92,
            "com_distance": 0.45,
            "axis": "along",
        },
        WHERE,
    )
    assert body.inertia == pytest.approx(0.595, abs=5e-4)


@pytest.mark.parametrize(
    ("spec", "pattern"),
    [
        ("disk", r"^study.toml: bodies.weight.ideal: expected a table"),
        ({"radius": 0.05}, r"^study.toml: bodies.weight.ideal.shape: missing; expected one of"),
        ({"shape": ["rod"]}, r"\.shape: unknown shape \['rod'\]; expected one of"),
        (
            {"shape": "cone"},
            r"\.shape: unknown shape 'cone'; expected one of 'solid-disk', .*'sphere'",
        ),
        (
            {"shape": "rod", "length": 0.5, "mass": 1.0, "density": 1000.0},
            r"\.density: unknown key for shape 'rod' \(allowed: shape, length, mass, com_distance\)",
        ),
        (
            {"shape": "solid-disk", "radius": 0.05, "mass": 1.0, "com_distance": 0.4},
            (
                r"\.thickness: missing; shape 'solid-disk' needs radius, thickness, com_distance "
                r"and one of mass/density"
            ),
        ),
        (
            {"shape": "sphere", "radius": -0.05, "mass": 1.0, "com_distance": 0.4},
            r"^study.toml: bodies.weight.ideal.radius: must be positive \(m\), got -0.05$",
        ),
        (
            {"shape": "box", "a": 0.1, "b": 0.2, "c": "0.3", "mass": 1.0},
            r"^study.toml: bodies.weight.ideal.c: expected a positive number \(m\), got '0.3'$",
        ),
        (
            {"shape": "square-tube", "outer": 0.03, "inner": 0.026, "length": 0.45},
            r"\.mass: give exactly one of mass \(kg\) or density \(kg/m\^3\), got neither",
        ),
        (
            {"shape": "solid-disk", **DISK, "axis": "sideways"},
            r"\.axis: expected one of 'along', 'across', got 'sideways'",
        ),
    ],
)
def test_ideal_body_errors(spec, pattern):
    with pytest.raises(InputError, match=pattern) as info:
        ideal_body(spec, WHERE)
    assert "\n" not in str(info.value)


def test_every_shape_name_is_documented_with_its_keys():
    assert set(SHAPES) == {
        "solid-disk",
        "solid-cylinder",
        "rod",
        "square-tube",
        "rectangular-tube",
        "box",
        "sphere",
    }


# --- bad inputs to the constructors ----------------------------------------------------------------


@pytest.mark.parametrize(
    ("call", "argument"),
    [
        (lambda: solid_disk(-0.05, 0.06, mass=1.0, com_distance=0.4), "radius"),
        (lambda: solid_disk(0.05, 0.0, mass=1.0, com_distance=0.4), "thickness"),
        (lambda: solid_disk(0.05, 0.06, mass=1.0, com_distance=-0.4), "com_distance"),
        (lambda: solid_disk(0.05, 0.06, mass=1.0, com_distance=math.nan), "com_distance"),
        (lambda: solid_disk(0.05, 0.06, mass=1.0, com_distance=0.4, axis="x"), "axis"),
        (lambda: solid_disk(0.05, 0.06, com_distance=0.4), "mass"),
        (lambda: solid_disk(0.05, 0.06, mass=1.0, density=7800, com_distance=0.4), "mass"),
        (lambda: solid_disk(0.05, 0.06, density=-7800, com_distance=0.4), "density"),
        (lambda: solid_cylinder(math.inf, 0.06, mass=1.0, com_distance=0.4), "radius"),
        (lambda: rod(0.0, mass=1.0), "length"),
        (lambda: rod(0.5, mass=0.0), "mass"),
        (lambda: rod(0.5, mass=True), "mass"),  # type: ignore[arg-type]
        (lambda: square_tube(0.03, 0.03, 0.45, mass=2.91), "inner"),
        (lambda: square_tube(0.03, 0.04, 0.45, mass=2.91), "inner"),
        (lambda: square_tube(0.03, -0.02, 0.45, mass=2.91), "inner"),
        (lambda: square_tube(-0.03, 0.02, 0.45, mass=2.91), "outer"),
        (lambda: square_tube(0.03, 0.02, 0.45, mass=math.nan), "mass"),
        (lambda: square_tube(0.03, 0.02, 0.45, mass=2.91, com_distance=-1), "com_distance"),
        (lambda: rectangular_tube(0.05, 0.03, 0.05, 0.02, 0.4, mass=1.0), "inner_w"),
        (lambda: rectangular_tube(0.05, 0.03, 0.04, 0.03, 0.4, mass=1.0), "inner_h"),
        (lambda: rectangular_tube(0.05, 0.03, 0.04, 0.02, -0.4, mass=1.0), "length"),
        (lambda: rectangular_tube(0.05, "3 cm", 0.04, 0.02, 0.4, mass=1.0), "outer_h"),  # type: ignore[arg-type]
        (lambda: box(0.1, 0.2, 0.0, density=1000.0), "c"),
        (lambda: box(0.1, None, 0.3, density=1000.0), "b"),  # type: ignore[arg-type]
        (lambda: sphere(0.05, com_distance=0.3), "mass"),
        (lambda: sphere(0.0, mass=1.0, com_distance=0.3), "radius"),
    ],
)
def test_bad_inputs_name_the_argument(call, argument):
    with pytest.raises(InputError) as info:
        call()
    message = str(info.value)
    assert "\n" not in message
    assert f": {argument}: " in message
