"""The README's results table, generated from ``benchmarks/results/`` so that it cannot drift.

    python benchmarks/readme_table.py            # print the table
    python benchmarks/readme_table.py --write    # put it into README.md between the markers

One row for every example of the paper (Sec. 4.1-4.5): the straight spin-up beam at ωs = 4, 10,
20 and 40 rad/s and the three curved beams (``results/table3.md``), the rotating membrane's two
cases (``results/membrane.md``), the beamlike truss (``results/truss.md``) and the three-beam
pendulum (``results/pendulum.md``): full-order and reduced DOFs, χ_rel, the spin-up beams' total
error and basis part against converged references (``results/table3_converged.md``), and the
speed-up of the reduced run over the full RNCF run, beside the paper's own figures for the same example where the
paper gives them ("—" where it does not). The results files are the markdown tables that
``table3.py``, ``table3_converged.py``, ``membrane.py``, ``truss.py`` and ``pendulum.py`` write; a row this script needs
and does not find stops it with the file's name (``ResultsError``).

The paper's figures are below (``PAPER``), each with the table or section of the paper it is read
from; its speed-ups are the ratios of the run times it reports. Its Tables 3, 5 and 7 lost their
numbers in the text this project has, so for the straight and curved beams only the bounds its text
states are given, and nothing for the membrane's in-plane case beyond its DOFs.
"""

import argparse
import dataclasses
import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
README = HERE.parent / "README.md"
START = "<!-- results-table:start -->"
END = "<!-- results-table:end -->"
DASH = "—"


class ResultsError(ValueError):
    """A results file lacks a table, a column or a row that the README's table needs."""


# ---------------------------------------------------------------------------------------------
# Reading the results files


@dataclasses.dataclass(frozen=True)
class Table:
    header: tuple[str, ...]
    rows: tuple[dict, ...]


def read_tables(path: Path) -> list[Table]:
    """Every markdown table of ``path``: a header line, a ``|---|`` line, then rows (cells
    stripped; an escaped ``\\|`` stays inside its cell)."""
    if not path.is_file():
        raise ResultsError(f"{path}: file not found")
    lines = path.read_text(encoding="utf-8").splitlines()
    tables, i = [], 0
    while i < len(lines):
        if (lines[i].startswith("|") and i + 1 < len(lines)
                and re.fullmatch(r"\|(\s*:?-+:?\s*\|)+\s*", lines[i + 1])):
            header = tuple(_cells(lines[i]))
            rows, i = [], i + 2
            while i < len(lines) and lines[i].startswith("|"):
                cells = _cells(lines[i])
                if len(cells) != len(header):
                    raise ResultsError(f"{path.name}: a row of {len(cells)} cells under a header of "
                                       f"{len(header)}: {lines[i]!r}")
                rows.append(dict(zip(header, cells)))
                i += 1
            tables.append(Table(header, tuple(rows)))
        else:
            i += 1
    return tables


def _cells(line: str) -> list[str]:
    body = line.strip()
    body = body[1:-1] if body.endswith("|") else body[1:]
    return [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", body)]


def find_row(path: Path, where: dict, columns=()) -> dict:
    """The one row of ``path``'s tables whose cells match ``where`` (column → exact text, or a
    ``cell`` predicate) and whose table has ``columns`` too."""
    need = set(where) | set(columns)
    candidates = [t for t in read_tables(path) if need <= set(t.header)]
    if not candidates:
        raise ResultsError(f"{path.name}: no table with the columns {sorted(need)}")
    found = [r for t in candidates for r in t.rows
             if all(v(r[k]) if callable(v) else r[k] == v for k, v in where.items())]
    described = {k: getattr(v, "description", v) for k, v in where.items()}
    if not found:
        raise ResultsError(f"{path.name}: no row with {described}")
    if len(found) > 1:
        raise ResultsError(f"{path.name}: {len(found)} rows with {described}, expected one")
    return found[0]


def cell(test, description: str):
    """A predicate on a cell's text, named for the error message."""
    test.description = description
    return test


def starts(prefix: str):
    return cell(lambda text: text.startswith(prefix), f"{prefix}...")


def ends(suffix: str):
    return cell(lambda text: text.endswith(suffix), f"...{suffix}")


def number(path: Path, text: str, column: str) -> float:
    """``text`` (a cell of ``column``) as a number, e.g. ``'41.8x'`` → 41.8, ``'19962'`` → 19962."""
    m = re.fullmatch(r"\s*([0-9][0-9,]*(?:\.[0-9]+)?)\s*[x×]?\s*", text)
    if not m:
        raise ResultsError(f"{path.name}: column {column!r} holds {text!r}, not a number")
    return float(m.group(1).replace(",", ""))


# ---------------------------------------------------------------------------------------------
# Formatting


def speedup(x: float) -> str:
    """A speed-up as the README shows it: one decimal below 100, whole numbers with thousands
    separators above."""
    return f"{x:.1f}×" if x < 100 else f"{x:,.0f}×"


def count(path: Path, text: str, column: str = "DOFs") -> str:
    """A DOF count with thousands separators (``'18900'`` → ``'18,900'``)."""
    return f"{int(number(path, text, column)):,}"


def percent(path: Path, text: str, column: str = "χ_rel [%]") -> str:
    """A χ_rel cell as the results give it, once checked to be a number."""
    number(path, text, column)
    return text


def basis(vms: int | str, mds: int | str, spin: int = 0) -> str:
    s = f"{vms} VM{'s' if str(vms) != '1' else ''} + {mds} MD{'s' if str(mds) != '1' else ''}"
    return s + (f" + {spin} spinning-state*" if spin else "")


@dataclasses.dataclass(frozen=True)
class Paper:
    """The paper's figures for one example, as text ("—" where it gives none), and where they are."""

    full_dofs: str = DASH
    dofs: str = DASH
    chi: str = DASH
    times: tuple[float, float] | None = None  # (full RNCF, NR-RNCF) run times [s], for the speed-up
    speedup: str | None = None  # a speed-up the paper states in words, when it gives no times
    source: str = DASH

    def speedup_text(self) -> str:
        if self.times is not None:
            return speedup(self.times[0] / self.times[1])
        return self.speedup or DASH


# The paper's figures (Yuan, Ren et al., Mech. Mach. Theory 185 (2023) 105290), with their source.
_STRAIGHT = "Table 2; χ_rel bound: Sec. 4.1"
PAPER = {
    # Table 2 (DOFs of RNCF and NR-RNCF); Sec. 4.1: "the maximum global relative error is less than
    # 1.5%" over the four speeds; run times only for ωs = 40: RNCF 12.71 s, NR-RNCF 1.56 s.
    ("straight", 4): Paper("111", "9", "< 1.5", source=_STRAIGHT),
    ("straight", 10): Paper("183", "14", "< 1.5", source=_STRAIGHT),
    ("straight", 20): Paper("291", "17", "< 1.5", source=_STRAIGHT),
    ("straight", 40): Paper("435", "22", "< 1.5", times=(12.71, 1.56), source="Table 2; Sec. 4.1"),
    # Sec. 4.2: RNCF "144 degrees of freedom"; Table 4: 9, 9, 16; "the maximum global relative error
    # is only 0.86%" over the three; "about 6 times faster than the RNCF".
    ("curved-upwind", 4): Paper("144", "9", "≤ 0.86", speedup="≈ 6×", source="Table 4; Sec. 4.2"),
    ("curved-downwind", 4): Paper("144", "9", "≤ 0.86", speedup="≈ 6×", source="Table 4; Sec. 4.2"),
    ("curved-out-of-plane", 4): Paper("144", "16", "≤ 0.86", speedup="≈ 6×", source="Table 4; Sec. 4.2"),
    # Sec. 4.3: 18,912 DOFs; "only two generalized coordinates (1VM+1MD)"; Table 7's columns
    # (RNCF, 1VM, 1VM+1MD) survive, its numbers do not.
    ("in-plane", 7, "md"): Paper("18,912", "2", source="Sec. 4.3, Table 7"),
    ("in-plane", 7, "vm"): Paper("18,912", "1", source="Sec. 4.3, Table 7"),
    ("in-plane", 10, "md"): Paper("18,912", "2", source="Sec. 4.3, Table 7"),
    ("in-plane", 10, "vm"): Paper("18,912", "1", source="Sec. 4.3, Table 7"),
    # Table 8: RNCF 18,912 DOFs, 3462 s; 3 VMs: 3 DOFs, 0.167 s, 43.8 %; 3 VMs + 6 MDs: 9, 0.384 s, 0.71 %.
    ("bending-torsion", 4, "md"): Paper("18,912", "9", "0.71", times=(3462, 0.384), source="Table 8"),
    ("bending-torsion", 4, "vm"): Paper("18,912", "3", "43.8", times=(3462, 0.167), source="Table 8"),
    # Table 12: RNCF 18,360 DOFs, 4886 s; 4 VMs: 4 DOFs, 0.193 s, 32.7 %; 4 VMs + 6 MDs: 10, 0.301 s, 0.36 %.
    ("truss", "md"): Paper("18,360", "10", "0.36", times=(4886, 0.301), source="Table 12"),
    ("truss", "vm"): Paper("18,360", "4", "32.7", times=(4886, 0.193), source="Table 12"),
    # Table 9: RNCF 558 DOFs, 443.41 s; NR-RNCF (extended Craig-Bampton, 5 VMs + 15 MDs a beam):
    # 84 DOFs, 76.31 s, 1.07 %.
    ("pendulum",): Paper("558", "84", "1.07", times=(443.41, 76.31), source="Table 9"),
}


# ---------------------------------------------------------------------------------------------
# The rows


@dataclasses.dataclass(frozen=True)
class Row:
    example: str
    basis: str
    full_dofs: str
    dofs: str
    chi: str
    speedup: str
    paper: Paper
    converged: str = DASH  # total (basis part) against a converged reference, where measured


def _spin_count(cell: str) -> tuple[str, int]:
    """``'6 + 1*'`` → ``('6', 1)``; ``'6'`` → ``('6', 0)``."""
    m = re.fullmatch(r"(\d+)(?:\s*\+\s*(\d+)\*)?", cell)
    if not m:
        raise ResultsError(f"table3.md: a basis size {cell!r}, expected 'n' or 'n + k*'")
    return m.group(1), int(m.group(2) or 0)


def _converged(results: Path, case: str, dofs: str) -> str:
    """``'total (basis)'`` of ``case`` in ``table3_converged.md``: the reduced run's total error
    against the converged full run and its basis part, in per cent; ``'—‡'`` where that run's basis
    has other DOFs than ``dofs``, table3's (the selection chose another basis there)."""
    path = results / "table3_converged.md"
    r = find_row(path, {"case": case}, ("DOFs", "total χ_rel [%]", "basis [%]"))
    if count(path, r["DOFs"]) != dofs:
        return DASH + "‡"
    return f"{percent(path, r['total χ_rel [%]'], 'total χ_rel [%]')} ({percent(path, r['basis [%]'], 'basis [%]')})"


def _table3_rows(results: Path) -> list[Row]:
    path = results / "table3.md"
    rows = []
    cols = ("DOFs", "VMs", "MDs", "χ_rel [%]", "speed-up vs RNCF")
    cases = [("straight", w, f"paper, ωs = {w}", f"Straight beam, ωs = {w} rad/s (4.1)") for w in (4, 10, 20, 40)]
    cases += [(beam, 4, f"{beam}, ωs = 4", f"Curved beam, {beam.removeprefix('curved-')}, ωs = 4 rad/s (4.2)")
              for beam in ("curved-upwind", "curved-downwind", "curved-out-of-plane")]
    for beam, w, case, label in cases:
        full = find_row(path, {"case": case, "model": "RNCF"}, cols)
        models = [("NR-RNCF", "")]
        if any(r["case"] == case and r["model"] == "NR-RNCF, paper basis"
               for t in read_tables(path) if "case" in t.header for r in t.rows):
            models.append(("NR-RNCF, paper basis", ", no spinning-state vectors"))
        for model, note in models:
            r = find_row(path, {"case": case, "model": model}, cols)
            (v, sv), (m, sm) = _spin_count(r["VMs"]), _spin_count(r["MDs"])
            rows.append(Row(label + note, basis(v, m, sv + sm), count(path, full["DOFs"]), count(path, r["DOFs"]),
                            percent(path, r["χ_rel [%]"]),
                            speedup(number(path, r["speed-up vs RNCF"], "speed-up vs RNCF")), PAPER[(beam, w)],
                            _converged(results, case, count(path, r["DOFs"])) if model == "NR-RNCF" else DASH))
    return rows


def _membrane_basis(path: Path, cell: str) -> tuple[str, str]:
    """``'VMs [2, 7, 18] + 6 MDs'`` → ``('3', '6')``."""
    m = re.fullmatch(r"VMs \[([0-9, ]+)\] \+ (\d+) MDs", cell)
    if not m:
        raise ResultsError(f"{path.name}: a basis {cell!r}, expected 'VMs [i, ...] + k MDs'")
    return str(len(m.group(1).split(","))), m.group(2)


def _membrane_rows(results: Path) -> list[Row]:
    path = results / "membrane.md"
    cols = ("DOFs", "χ_rel [%]", "speed-up")
    rows = []
    for case, w, label in (("in-plane", 7, "Membrane, in-plane, ωs = 7 rad/s (4.3)"),
                           ("in-plane", 10, "Membrane, in-plane, ωs = 10 rad/s (4.3)"),
                           ("bending-torsion", 4, "Membrane, bending-torsion, ωs = 4 rad/s (4.3)")):
        full = find_row(path, {"case": case, "ωs [rad/s]": str(w), "model": "rncf"}, cols)
        with_mds = cell(lambda text: not text.endswith("+ 0 MDs"), "VMs [...] + k MDs, k > 0")
        for kind, mds in (("md", with_mds), ("vm", ends("+ 0 MDs"))):
            r = find_row(path, {"case": case, "ωs [rad/s]": str(w), "model": "nr-rncf", "basis (0-based)": mds}, cols)
            v, m = _membrane_basis(path, r["basis (0-based)"])
            rows.append(Row(label, basis(v, m), count(path, full["DOFs"]), count(path, r["DOFs"]),
                            percent(path, r["χ_rel [%]"]),
                            speedup(number(path, r["speed-up"], "speed-up")), PAPER[(case, w, kind)]))
    return rows


def _truss_rows(results: Path) -> list[Row]:
    path = results / "truss.md"
    cols = ("DOFs", "basis", "χ_rel [%]", "speed-up")
    full = find_row(path, {"model": "rncf"}, cols)
    rows = []
    for kind, suffix in (("md", "+ 6 MDs"), ("vm", "+ 0 MDs")):
        r = find_row(path, {"model": "nr-rncf", "basis": ends(suffix)}, cols)
        m = re.fullmatch(r"(\d+) VMs \[[0-9, ]+\] \+ (\d+) MDs", r["basis"])
        if not m:
            raise ResultsError(f"{path.name}: a basis {r['basis']!r}, expected 'n VMs [i, ...] + k MDs'")
        rows.append(Row("Beamlike truss, resonant tip load (4.5)", basis(m.group(1), m.group(2)),
                        count(path, full["DOFs"]), count(path, r["DOFs"]), percent(path, r["χ_rel [%]"]),
                        speedup(number(path, r["speed-up"], "speed-up")),
                        PAPER[("truss", kind)]))
    return rows


def _pendulum_rows(results: Path) -> tuple[list[Row], str]:
    path = results / "pendulum.md"
    rncf = find_row(path, {"model": starts("RNCF, 10 elements")}, ("DOFs", "χ_rel vs ANCF [%]"))
    ancf = find_row(path, {"elements a beam": "10"}, ("DOFs", "rtol", "max joint violation [m]"))
    cols = ("DOFs", "χ_rel [%]", "speed-up vs ANCF", "speed-up vs RNCF")
    rows = []
    for where, label in (("5 VMs + 15 MDs", "5 VMs + 15 MDs a beam"), (starts("extended Craig-Bampton"), None)):
        r = find_row(path, {"basis a beam": where}, cols)
        label = label or r["basis a beam"].removeprefix("extended ") + " a beam"
        s_rncf = number(path, r["speed-up vs RNCF"], "speed-up vs RNCF")
        s_ancf = number(path, r["speed-up vs ANCF"], "speed-up vs ANCF")
        rows.append(Row("Three-beam pendulum (4.4)", label, count(path, rncf["DOFs"]), count(path, r["DOFs"]),
                        percent(path, r["χ_rel [%]"]) + "†",
                        f"{speedup(s_rncf)} ({speedup(s_ancf)} vs ANCF)", PAPER[("pendulum",)]))
    return rows, count(path, ancf["DOFs"])


def _membrane_total_dofs(results: Path) -> str:
    """The membrane's DOFs in all, from its results' description line ('... 18912 DOFs (18900 free)')."""
    path = results / "membrane.md"
    if not path.is_file():
        raise ResultsError(f"{path}: file not found")
    m = re.search(r"(\d+) DOFs \((\d+) free\)", path.read_text(encoding="utf-8"))
    if not m:
        raise ResultsError(f"{path.name}: no line '... N DOFs (M free)'")
    return count(path, m.group(1))


def rows(results: Path = RESULTS) -> tuple[list[Row], dict]:
    pendulum, ancf_dofs = _pendulum_rows(results)
    out = _table3_rows(results) + _membrane_rows(results) + pendulum + _truss_rows(results)  # the paper's order
    return out, {"pendulum_ancf_dofs": ancf_dofs, "membrane_total_dofs": _membrane_total_dofs(results)}


HEAD = ("example (paper Sec.)", "reduced basis", "DOFs full → reduced", "χ_rel [%]",
        "vs converged: total (basis) [%]", "speed-up vs full RNCF",
        "paper: DOFs", "paper: χ_rel [%]", "paper: speed-up", "paper: source")


def table(results: Path = RESULTS) -> str:
    """The README's table and its notes, as markdown."""
    rs, extra = rows(results)
    lines = ["| " + " | ".join(HEAD) + " |", "|---|---|---:|---:|---:|---:|---:|---:|---:|---|"]
    for r in rs:
        p = r.paper
        paper_dofs = DASH if p.full_dofs == DASH and p.dofs == DASH else f"{p.full_dofs} → {p.dofs}"
        lines.append("| " + " | ".join((r.example, r.basis, f"{r.full_dofs} → {r.dofs}", r.chi, r.converged, r.speedup,
                                        paper_dofs, p.chi, p.speedup_text(), p.source)) + " |")
    notes = [
        "",
        "- Generated by `python benchmarks/readme_table.py --write` from `benchmarks/results/` (`table3.md`, "
        "`table3_converged.md`, `membrane.md`, `truss.md`, `pendulum.md`, where the machine, the dates and every "
        "other column are); "
        "`tests/test_readme.py` checks that this table is what the script makes of the committed results.",
        "- χ_rel: Eq. 40 over all nodal displacements, against the full RNCF run (†: the pendulum's against its "
        f"full ANCF run, {extra['pendulum_ancf_dofs']} DOFs, the same equations in other coordinates). Speed-up: "
        "the full RNCF run's time over the reduced run's, compilation and the offline stage left out; "
        "timings from a shared 2-core CPU, which vary by tens of per cent from run to run.",
        "- χ_rel compares two runs at the same tolerance (rtol 1e-4), each with its own time-integration error. "
        "*vs converged*: the reduced run at those tolerances against the full RNCF run at a hundredth of them "
        "(`table3_converged.md`): the error a user gets, and in brackets its basis part (the reduced model at the "
        "reference's tolerances against it); the rest is time integration. \"—\": not measured; the membrane's "
        "and truss's converged full runs would take hours, and the pendulum's reference is its ANCF run at the "
        "same tolerance. ‡ (where shown): the converged run's basis has other DOFs than this row's (the two "
        "scripts choose each basis anew).",
        "- *: spinning-state vectors (a spinning mode and modal derivatives of spinning modes, beyond the paper; "
        "`nr_rncf(full, ts, Basis(spin_state=False))` leaves them out, as in the rows \"no spinning-state vectors\"). "
        f"Full DOFs are the free coordinates (the membrane has {extra['membrane_total_dofs']} in all, as the paper "
        "counts); the truss is a substitute geometry (`scenarios.truss`), since the paper's Table 10 is lost; the "
        "pendulum's bases hold each beam's lowest in-plane modes.",
        "- Paper: its speed-ups are the ratios of the run times it reports. Its Tables 3, 5 and 7 lost their "
        "numbers in the text this project has: for the beams only the bounds its text states are given "
        "(\"less than 1.5%\" over the four speeds, \"only 0.86%\" over the three curved beams, \"about 6 times "
        "faster\"); \"—\" where it gives no figure.",
    ]
    return "\n".join(lines + notes)


def replace_between_markers(text: str, block: str, path: Path = README) -> str:
    if text.count(START) != 1 or text.count(END) != 1 or text.index(START) > text.index(END):
        raise ResultsError(f"{path.name}: expected one {START} followed by one {END}")
    head, rest = text.split(START)
    _, tail = rest.split(END)
    return f"{head}{START}\n{block}\n{END}{tail}"


def readme_block(text: str, path: Path = README) -> str:
    """What lies between the markers of ``text`` (the README), without the newlines around it."""
    if text.count(START) != 1 or text.count(END) != 1:
        raise ResultsError(f"{path.name}: expected one {START} and one {END}")
    return text.split(START)[1].split(END)[0].strip("\n")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--write", action="store_true", help="write the table into README.md between its markers")
    ap.add_argument("--results", type=Path, default=RESULTS, help="the results folder (default: %(default)s)")
    ap.add_argument("--readme", type=Path, default=README, help="the README (default: %(default)s)")
    a = ap.parse_args(argv)
    try:
        block = table(a.results)
        if a.write:
            text = a.readme.read_text(encoding="utf-8")
            new = replace_between_markers(text, block, a.readme)
            if new != text:
                a.readme.write_text(new, encoding="utf-8")
            print(f"{a.readme}: results table {'updated' if new != text else 'already up to date'}")
        else:
            print(block)
    except ResultsError as e:
        print(f"readme_table: error: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
