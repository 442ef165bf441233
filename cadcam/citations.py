"""The papers cadcam implements, by the tags its code and results cite (``Johnston2023 Eq. 14``).

Every symbolic function names its source as ``# <tag> Eq. N``; every result lists the papers of
the mechanisms and objective it used (:func:`cited`).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass


@dataclass(frozen=True)
class Paper:
    """One paper: authors, year, title, where it appeared and its DOI (None if unknown)."""

    authors: str
    year: int
    title: str
    venue: str
    doi: str | None


PAPERS = {
    "Johnston2023": Paper(
        "G. L. H. Johnston, A. L. Orekhov, N. Simaan", 2023,
        "Design considerations and robustness to parameter uncertainty in wire-wrapped cam "
        "mechanisms", "ASME Journal of Mechanisms and Robotics 15(3)", "10.1115/1.4056600"),
    "Ludovico2021": Paper(
        "D. Ludovico, P. Guardiani, F. Lasagni, J. Lee, F. Cannella, D. G. Caldwell", 2021,
        "Design of non-circular pulleys for torque generation: a convex optimisation approach",
        "IEEE Robotics and Automation Letters 6(2)", "10.1109/LRA.2021.3056358"),
    "Endo2010": Paper(
        "G. Endo, H. Yamada, A. Yajima, M. Ogata, S. Hirose", 2010,
        "A passive weight compensation mechanism with a non-circular pulley and a spring",
        "IEEE International Conference on Robotics and Automation (ICRA)", None),
    "Fedorov2018": Paper(
        "D. Fedorov, L. Birglen", 2018,
        "Differential noncircular pulleys for cable robots and static balancing",
        "ASME Journal of Mechanisms and Robotics 10(6)", "10.1115/1.4041213"),
}


def register_paper(tag: str, paper: Paper) -> str:
    """Make ``paper`` citable as ``tag`` (a mechanism's folder registers its own source);
    ValueError if the tag names another paper."""
    if PAPERS.setdefault(tag, paper) != paper:
        raise ValueError(f"a paper tagged {tag!r} is already registered")
    return tag


def cited(tags) -> list[dict]:
    """The registry entries of ``tags`` (unique, in order) as plain data for a result."""
    out = []
    for tag in dict.fromkeys(tags):
        if tag not in PAPERS:
            raise KeyError(f"unknown citation {tag!r}; known: {sorted(PAPERS)}")
        out.append({"key": tag, **asdict(PAPERS[tag])})
    return out
