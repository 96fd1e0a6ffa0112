"""The reference list of a result: ``references.bib`` and the list shown in report.html.

:data:`REFERENCES` holds every work inertiafit may cite, as BibTeX fields: authors, year,
title, journal or publisher, volume, pages and DOI wherever they exist (the method paper keeps
what its copy states, and says in its ``note`` what that copy does not). The Methods text
(:mod:`inertiafit.report.methods`) cites a work by its key (:func:`cite`) where it uses it: a
prior's source is quoted with the works it names (:func:`citations`, found by each work's
``markers``), and ``references.bib`` holds exactly the works the text cites. :func:`cited`
lists the works a set of source texts names, after the method paper and the software.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

__all__ = [
    "ALWAYS",
    "REFERENCES",
    "Reference",
    "bibtex",
    "citations",
    "cite",
    "cited",
    "reference_text",
]


@dataclass(frozen=True)
class Reference:
    """One work: its BibTeX key, entry type and fields; ``markers`` cite it when found.

    A source text (a prior file's ``source``, an anthropometric table's citation) that holds
    one of ``markers`` cites this work.
    """

    key: str
    kind: str
    fields: Mapping[str, str]
    markers: tuple[str, ...] = field(default=())

    @property
    def short(self) -> str:
        """``Author et al. (year)`` or ``Author (year)`` for the text."""
        authors = _plain(self.fields.get("author", "")).split(" and ")
        first = authors[0].split(",")[0].strip() or self.key
        etal = " et al." if len(authors) > 2 or "others" in authors else ""
        if len(authors) == 2 and "others" not in authors:
            etal = f" & {authors[1].split(',')[0].strip()}"
        year = self.fields.get("year")
        return f"{first}{etal}" + (f" ({year})" if year else "")


REFERENCES: dict[str, Reference] = {
    r.key: r
    for r in (
        Reference(
            "son_dynamometer",
            "article",
            {
                "author": "Son, J. and others",
                "title": "Determination of inertial parameters using a dynamometer",
                "note": (
                    "The method paper. The copy inertiafit was built from states no journal, "
                    "volume, year or page range: its running head reads 'J. Son et al. / "
                    "Determination of inertial parameters using a dynamometer' and one of its "
                    "pages is numbered 2454; add the venue from the published article"
                ),
            },
            ("Son et al.",),
        ),
        Reference(
            "foreman_mackey_emcee_2013",
            "article",
            {
                "author": "Foreman-Mackey, Daniel and Hogg, David W. and Lang, Dustin and "
                "Goodman, Jonathan",
                "title": "emcee: The {MCMC} Hammer",
                "journal": "Publications of the Astronomical Society of the Pacific",
                "volume": "125",
                "number": "925",
                "pages": "306--312",
                "year": "2013",
                "doi": "10.1086/670067",
            },
        ),
        Reference(
            "kumar_arviz_2019",
            "article",
            {
                "author": "Kumar, Ravin and Carroll, Colin and Hartikainen, Ari and Martin, "
                "Osvaldo",
                "title": "{ArviZ} a unified library for exploratory analysis of {Bayesian} "
                "models in {Python}",
                "journal": "Journal of Open Source Software",
                "volume": "4",
                "number": "33",
                "pages": "1143",
                "year": "2019",
                "doi": "10.21105/joss.01143",
            },
        ),
        Reference(
            "vehtari_rhat_2021",
            "article",
            {
                "author": "Vehtari, Aki and Gelman, Andrew and Simpson, Daniel and Carpenter, "
                'Bob and B{\\"u}rkner, Paul-Christian',
                "title": "Rank-normalization, folding, and localization: An improved "
                "$\\widehat{R}$ for assessing convergence of {MCMC}",
                "journal": "Bayesian Analysis",
                "volume": "16",
                "number": "2",
                "pages": "667--718",
                "year": "2021",
                "doi": "10.1214/20-BA1221",
            },
        ),
        Reference(
            "foreman_mackey_corner_2016",
            "article",
            {
                "author": "Foreman-Mackey, Daniel",
                "title": "corner.py: Scatterplot matrices in {Python}",
                "journal": "Journal of Open Source Software",
                "volume": "1",
                "number": "2",
                "pages": "24",
                "year": "2016",
                "doi": "10.21105/joss.00024",
            },
        ),
        Reference(
            "de_leva_1996",
            "article",
            {
                "author": "de Leva, Paolo",
                "title": "Adjustments to {Zatsiorsky-Seluyanov}'s segment inertia parameters",
                "journal": "Journal of Biomechanics",
                "volume": "29",
                "number": "9",
                "pages": "1223--1230",
                "year": "1996",
                "doi": "10.1016/0021-9290(95)00178-6",
            },
            ("de Leva",),
        ),
        Reference(
            "winter_2009",
            "book",
            {
                "author": "Winter, David A.",
                "title": "Biomechanics and Motor Control of Human Movement",
                "edition": "4th",
                "publisher": "John Wiley \\& Sons",
                "address": "Hoboken, NJ",
                "year": "2009",
                "doi": "10.1002/9780470549148",
                "note": "Table 4.1",
            },
            ("Winter D.A.",),
        ),
        Reference(
            "dempster_1955",
            "techreport",
            {
                "author": "Dempster, Wilfrid Taylor",
                "title": "Space requirements of the seated operator",
                "institution": "Wright Air Development Center, Wright-Patterson Air Force "
                "Base, Ohio",
                "type": "WADC Technical Report",
                "number": "55-159",
                "year": "1955",
            },
            ("Dempster",),
        ),
        Reference(
            "durkin_dowling_2003",
            "article",
            {
                "author": "Durkin, Jennifer L. and Dowling, James J.",
                "title": "Analysis of body segment parameter differences between four human "
                "populations and the estimation errors of four popular mathematical models",
                "journal": "Journal of Biomechanical Engineering",
                "volume": "125",
                "number": "4",
                "pages": "515--522",
                "year": "2003",
                "doi": "10.1115/1.1590359",
            },
            ("Durkin & Dowling",),
        ),
        Reference(
            "rossi_2013",
            "article",
            {
                "author": "Rossi, Marcel and Lyttle, Andrew and El-Sallam, Amar and "
                "Benjanuvatra, Nat and Blanksby, Brian",
                "title": "Body segment inertial parameters of elite swimmers using {DXA} and "
                "indirect methods",
                "journal": "Journal of Sports Science and Medicine",
                "volume": "12",
                "number": "4",
                "pages": "761--775",
                "year": "2013",
            },
            ("Rossi et al.",),
        ),
        Reference(
            "merrill_2019",
            "article",
            {
                "author": "Merrill, Z. and Perera, S. and Cham, R.",
                "title": "Predictive regression modeling of body segment parameters using "
                "individual-based anthropometric measurements",
                "journal": "Journal of Biomechanics",
                "volume": "96",
                "pages": "109349",
                "year": "2019",
                "doi": "10.1016/j.jbiomech.2019.109349",
                "note": "PMCID PMC6905426",
            },
            ("Merrill et al.",),
        ),
        Reference(
            "riener_edrich_1999",
            "article",
            {
                "author": "Riener, Robert and Edrich, Thomas",
                "title": "Identification of passive elastic joint moments in the lower "
                "extremities",
                "journal": "Journal of Biomechanics",
                "volume": "32",
                "number": "5",
                "pages": "539--544",
                "year": "1999",
                "doi": "10.1016/S0021-9290(99)00009-3",
            },
            ("Riener & Edrich",),
        ),
        Reference(
            "anderson_1999",
            "phdthesis",
            {
                "author": "Anderson, III, Frank Clayton",
                "title": "A dynamic optimization solution for a complete cycle of normal gait",
                "school": "The University of Texas at Austin",
                "year": "1999",
            },
            ("Anderson 1999",),
        ),
        Reference(
            "solin_sarkka_2020",
            "article",
            {
                "author": 'Solin, Arno and S{\\"a}rkk{\\"a}, Simo',
                "title": "Hilbert space methods for reduced-rank {Gaussian} process regression",
                "journal": "Statistics and Computing",
                "volume": "30",
                "number": "2",
                "pages": "419--446",
                "year": "2020",
                "doi": "10.1007/s11222-019-09886-w",
            },
        ),
        Reference(
            "riutort_mayol_2023",
            "article",
            {
                "author": 'Riutort-Mayol, G. and B{\\"u}rkner, Paul-Christian and '
                "Andersen, M. R. and Solin, Arno and Vehtari, Aki",
                "title": "Practical {Hilbert} space approximate {Bayesian} {Gaussian} processes "
                "for probabilistic programming",
                "journal": "Statistics and Computing",
                "volume": "33",
                "number": "1",
                "pages": "17",
                "year": "2023",
                "doi": "10.1007/s11222-022-10167-2",
            },
        ),
        Reference(
            "wiegner_watts_1986",
            "article",
            {
                "author": "Wiegner, A. W. and Watts, R. L.",
                "title": "Elastic properties of muscles measured at the elbow in man: {I}. "
                "Normal controls",
                "journal": "Journal of Neurology, Neurosurgery, and Psychiatry",
                "volume": "49",
                "number": "10",
                "pages": "1171",
                "year": "1986",
                "doi": "10.1136/jnnp.49.10.1171",
                "note": "first page only",
            },
            ("Wiegner & Watts",),
        ),
        Reference(
            "hermens_2000",
            "article",
            {
                "author": "Hermens, Hermie J. and Freriks, Bart and Disselhorst-Klug, "
                'Catherine and Rau, G{\\"u}nter',
                "title": "Development of recommendations for {SEMG} sensors and sensor "
                "placement procedures",
                "journal": "Journal of Electromyography and Kinesiology",
                "volume": "10",
                "number": "5",
                "pages": "361--374",
                "year": "2000",
                "doi": "10.1016/S1050-6411(00)00027-4",
            },
            ("Hermens et al.",),
        ),
        Reference(
            "hodges_bui_1996",
            "article",
            {
                "author": "Hodges, Paul W. and Bui, Bang H.",
                "title": "A comparison of computer-based methods for the determination of "
                "onset of muscle contraction using electromyography",
                "journal": "Electroencephalography and Clinical Neurophysiology",
                "volume": "101",
                "number": "6",
                "pages": "511--519",
                "year": "1996",
                "doi": "10.1016/S0921-884X(96)95190-5",
            },
            ("Hodges & Bui",),
        ),
    )
}

#: Cited by every result: the method paper and the software that sampled and checked it.
ALWAYS = (
    "son_dynamometer",
    "foreman_mackey_emcee_2013",
    "kumar_arviz_2019",
    "vehtari_rhat_2021",
    "foreman_mackey_corner_2016",
)


def cited(sources: Iterable[str], *, emg: bool = False) -> list[Reference]:
    """:data:`ALWAYS`, then every reference a source text names, then the EMG ones if ``emg``.

    ``sources`` are the texts a study's priors cite (a prior file's ``source``, an
    anthropometric table's citation, a passive prior file); a reference is cited when one of
    its markers is in one of them.
    """
    text = "\n".join(sources)
    keys = list(ALWAYS)
    keys += [r.key for r in REFERENCES.values() if r.markers and any(m in text for m in r.markers)]
    if emg:
        keys += ["hermens_2000", "hodges_bui_1996"]
    return [REFERENCES[k] for k in dict.fromkeys(keys)]


def citations(text: str) -> list[str]:
    """The keys of the works a source text names (one of their markers is in it), in order."""
    return [r.key for r in REFERENCES.values() if any(m in text for m in r.markers)]


def cite(keys: Iterable[str]) -> str:
    """A Pandoc citation of ``keys``: ``[@a]``, ``[@a; @b]``; ``""`` for none.

    Raises
    ------
    KeyError
        A key that is not in :data:`REFERENCES` (a citation ``references.bib`` could not
        resolve).
    """
    keys = list(dict.fromkeys(keys))
    unknown = [k for k in keys if k not in REFERENCES]
    if unknown:  # a bug: fail where the citation is written, not in a reader's Pandoc run
        raise KeyError(f"no reference {unknown[0]!r} in REFERENCES")
    return f"[{'; '.join(f'@{k}' for k in keys)}]" if keys else ""


def bibtex(references: Iterable[Reference]) -> str:
    """The references as one BibTeX file."""
    entries = []
    for r in references:
        width = max(len(k) for k in r.fields)
        body = ",\n".join(f"  {k:<{width}} = {{{v}}}" for k, v in r.fields.items())
        entries.append(f"@{r.kind}{{{r.key},\n{body}\n}}\n")
    return "\n".join(entries)


#: The TeX of the few accents and symbols the entries use, and their characters.
_TEX = (('{\\"u}', "ü"), ('{\\"a}', "ä"), ("$\\widehat{R}$", "R-hat"), ("\\&", "&"))


def _plain(text: str) -> str:
    """BibTeX field text for reading: braces and the few accents used here removed."""
    for tex, ch in _TEX:
        text = text.replace(tex, ch)
    return text.replace("{", "").replace("}", "").replace("--", "–")


def reference_text(ref: Reference) -> str:
    """One reference as a line of text: authors (year). Title. Journal volume, pages. doi."""
    f = {k: _plain(v) for k, v in ref.fields.items()}
    authors = f.get("author", "").replace(" and others", " et al.").replace(" and ", "; ")
    parts = [f"{authors} ({f['year']})." if "year" in f else authors.rstrip(".") + "."]
    if "title" in f:
        parts.append(f"{f['title']}.")
    if "journal" in f:
        detail = " ".join(
            filter(
                None,
                [f["journal"], f.get("volume", ""), f"({f['number']})" if "number" in f else ""],
            )
        )
        parts.append(detail + (f", {f['pages']}." if "pages" in f else "."))
    else:  # a book, a report, a thesis: who published it, and which one
        what = [f"{f['edition']} ed." if "edition" in f else ""]
        what.append(" ".join(filter(None, [f.get("type", ""), f.get("number", "")])))
        if ref.kind == "phdthesis":
            what.append("PhD thesis")
        what += [f.get(k, "") for k in ("publisher", "institution", "school", "address")]
        if any(what):
            parts.append(", ".join(filter(None, what)) + ".")
    if "doi" in f:
        parts.append(f"doi:{f['doi']}")
    if "note" in f:
        parts.append(f"[{f['note']}]")
    return " ".join(parts)
