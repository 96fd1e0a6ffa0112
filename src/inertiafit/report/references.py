"""The reference list of a result: ``references.bib`` and the list shown in report.html.

:data:`REFERENCES` holds every work inertiafit may cite, as BibTeX fields. :func:`cited` picks
those a result uses: the method paper and the software always; an anthropometric table, the
passive-joint sources or the EMG sources when the study's priors, its living joint or its
trials draw on them (found by name in the sources its prior files give).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

__all__ = [
    "ALWAYS",
    "REFERENCES",
    "Reference",
    "bibtex",
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
        authors = self.fields.get("author", "").split(" and ")
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
                    "The method paper. The copy inertiafit was built from gives the running "
                    "head 'J. Son et al. / Determination of inertial parameters using a "
                    "dynamometer' and page 2454; add the journal, volume, year and pages from "
                    "the published article"
                ),
            },
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
                "publisher": "Wiley",
                "year": "2009",
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
                "institution": "Wright-Patterson Air Force Base",
                "number": "WADC-TR-55-159",
                "year": "1955",
            },
            ("Dempster",),
        ),
        Reference(
            "durkin_dowling_2003",
            "article",
            {
                "author": "Durkin, Jennifer L. and Dowling, James J.",
                "journal": "Journal of Biomechanical Engineering",
                "volume": "125",
                "pages": "515--522",
                "year": "2003",
                "note": "guides the spread of the anthropometric priors",
            },
            ("Durkin & Dowling",),
        ),
        Reference(
            "rossi_2013",
            "article",
            {
                "author": "Rossi, M. and others",
                "journal": "Journal of Sports Science and Medicine",
                "volume": "12",
                "pages": "761--775",
                "year": "2013",
                "note": "guides the spread of the anthropometric priors",
            },
            ("Rossi et al.",),
        ),
        Reference(
            "merrill_2019",
            "article",
            {
                "author": "Merrill, Z. and others",
                "year": "2019",
                "note": "PMC6905426; guides the spread of the anthropometric priors",
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
                "pages": "539--544",
                "year": "1999",
            },
            ("Riener & Edrich",),
        ),
        Reference(
            "wiegner_watts_1986",
            "article",
            {
                "author": "Wiegner, A. W. and Watts, R. L.",
                "journal": "Journal of Neurology, Neurosurgery, and Psychiatry",
                "volume": "49",
                "pages": "1171",
                "year": "1986",
                "note": "relaxed elbow stiffness",
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


def bibtex(references: Iterable[Reference]) -> str:
    """The references as one BibTeX file."""
    entries = []
    for r in references:
        width = max(len(k) for k in r.fields)
        body = ",\n".join(f"  {k:<{width}} = {{{v}}}" for k, v in r.fields.items())
        entries.append(f"@{r.kind}{{{r.key},\n{body}\n}}\n")
    return "\n".join(entries)


def _plain(text: str) -> str:
    """BibTeX field text for reading: braces and the few accents used here removed."""
    for tex, ch in (('{\\"u}', "ü"), ("$\\widehat{R}$", "R-hat")):
        text = text.replace(tex, ch)
    return text.replace("{", "").replace("}", "").replace("--", "–")


def reference_text(ref: Reference) -> str:
    """One reference as a line of text: authors (year). Title. Journal volume, pages. doi."""
    f = {k: _plain(v) for k, v in ref.fields.items()}
    authors = f.get("author", "").replace(" and others", " et al.").replace(" and ", "; ")
    parts = [f"{authors} ({f['year']})." if "year" in f else authors.rstrip(".") + "."]
    if "title" in f:
        parts.append(f"{f['title']}.")
    venue = f.get("journal") or f.get("publisher") or f.get("institution") or ""
    if venue:
        detail = " ".join(
            filter(
                None,
                [venue, f.get("volume", ""), f"({f['number']})" if "number" in f else ""],
            )
        )
        parts.append(detail + (f", {f['pages']}." if "pages" in f else "."))
    if "doi" in f:
        parts.append(f"doi:{f['doi']}")
    if "note" in f:
        parts.append(f"[{f['note']}]")
    return " ".join(parts)
