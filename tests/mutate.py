"""Mutation testing of the kernels: small faults put into one chapter's ``clkernels/<stem>.cl``, each run through the
chapter's own tests, which should fail ("kill" the mutant). A script, not a test module (pytest collects only
``test_*.py``); ``make mutate`` runs it, and docs/testing.md says how to read its output.

    python tests/mutate.py --chapter boids [--mutants 15] [--seed 0] [--jobs 2] [--timeout 300] [--json out.json]
    python tests/mutate.py --chapter all --list

Each mutant is built and tested in isolation: a copy of ``clkernels/`` in a temporary folder, the one change made
there, and pytest run with ``UGPCL_KERNELS`` naming that folder (``ugpcl.runtime.kernel_dirs`` puts it first, so
``Runtime.program(stem)`` builds the mutated file; headers are always inlined from the package's
``clkernels/include/``, so only the ``.cl`` file itself is mutated). PyOpenCL caches binaries by source text, so a
mutated file is always rebuilt.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import FIRST_COMPLETED, ThreadPoolExecutor, wait
from dataclasses import asdict, dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
KERNELS = ROOT / "clkernels"

# Test files of each kernel file, where they are not just tests/test_<stem>.py. The shared helpers (grid, pool,
# random, probes) are mutated against their own tests only: the chapters that use them test them again, slower.
TESTS = {
    "ear_clipping": ["tests/test_ear_clipping.py", "tests/test_ear_clipping_robust.py"],
    # test_space_colonization_cpu.py has no kernels; test_space_colonization_skinned.py builds its own .cl file
    "space_colonization": ["tests/test_space_colonization.py"],
    "probes": ["tests/test_benchmark.py::test_probes_compute_what_they_claim"],
}
# A chapter without a kernel file of its own: the file its scene runs, mutated against the chapter's own tests
# (tessellation steps the 2D fluid; its tessellation shaders are GLSL, which this tool does not mutate).
BORROWED = {"tessellation": "stable_fluids_2d"}
PYTEST_ARGS = ["-x", "-q", "-p", "no:cacheprovider", "-m", "not oclgrind"]
POISON = "ugpcl-mutate-poison"


def chapter_tests(stem: str) -> list[str]:
    tests = TESTS.get(stem, [f"tests/test_{stem}.py"])
    missing = [t for t in tests if not (ROOT / t.split("::")[0]).is_file()]
    if missing:
        raise SystemExit(f"mutate: {stem}.cl: no test file {', '.join(missing)} (add it to TESTS in {__file__})")
    return tests


# {{{ mutation sites

TOKEN = re.compile(
    r"(?P<space>\s+)"
    r"|(?P<number>0[xX][0-9a-fA-F]+[uUlL]*|(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?[fFhHuUlL]*)"
    r"|(?P<name>[A-Za-z_]\w*)"
    r"|(?P<op><<=|>>=|->|\+\+|--|&&|\|\||<<|>>|[-+*/%&|^!=<>]=|.)",
    re.S,
)
COMMENT_OR_STRING = re.compile(r"//[^\n]*|/\*.*?\*/|\"(?:\\.|[^\"\\\n])*\"|'(?:\\.|[^'\\\n])*'", re.S)
DIRECTIVE = re.compile(r"^[ \t]*#[ \t]*(\w*)(?:[^\n]*\\\n)*[^\n]*", re.M)
DEFINE_HEAD = re.compile(r"[ \t]*#[ \t]*define[ \t]+\w+(?:\([^)]*\))?")
BUILTIN_TYPE = re.compile(
    r"(?:u?(?:char|short|int|long)|float|double|half|bool|void|size_t|ptrdiff_t|u?intptr_t|unsigned|signed"
    r"|image[123]d_t|image[12]d_array_t|image1d_buffer_t|sampler_t|event_t)(?:2|3|4|8|16)?"
)
# Words after which `*` is a pointer or a dereference and `[` an array declaration, not arithmetic or an index.
NOT_OPERANDS = set(
    "const volatile restrict __global global __local local __constant constant __private private __kernel kernel "
    "__read_only read_only __write_only write_only __read_write read_write static inline struct union enum "
    "return case else do goto typedef".split()
)
SWAPS = {"+": "-", "-": "+", "+=": "-=", "-=": "+=", "*=": "/=", "/=": "*=", "/": "*", "<": "<=", "<=": "<",
         ">": ">=", ">=": ">", "==": "!=", "!=": "==", "&&": "||", "||": "&&"}  # fmt: skip


@dataclass
class Mutant:
    """Text ``[start, end)`` of the kernel file replaced by ``after``."""

    start: int
    end: int
    after: str
    kind: str
    line: int = 0
    before_text: str = ""
    after_text: str = ""


def blank(chars: list[str], start: int, end: int) -> None:
    """Spaces over chars[start:end], newlines kept, so offsets and line numbers stay those of the file."""
    for i in range(start, end):
        if chars[i] != "\n":
            chars[i] = " "


def closing(masked: str, start: int, pair: str) -> int:
    """Index of the bracket that closes the one at ``start`` (``pair`` = "()" or "[]"), -1 if unbalanced."""
    depth = 0
    for i in range(start, len(masked)):
        depth += (masked[i] == pair[0]) - (masked[i] == pair[1])
        if depth == 0:
            return i
    return -1


def code_only(text: str) -> str:
    """``text`` with comments, strings, preprocessor lines (but for #define bodies: their constants are code) and
    ``__attribute__((...))`` blanked: what is left are the places a mutation may go."""
    chars = list(text)
    for m in COMMENT_OR_STRING.finditer(text):
        blank(chars, m.start(), m.end())
    masked = "".join(chars)
    for m in DIRECTIVE.finditer(masked):
        if m[1] == "define":  # mutate the body, never the macro's name or parameters
            blank(chars, m.start(), DEFINE_HEAD.match(masked, m.start()).end())
        else:  # #include, #if, #pragma ...: mutating them tests the preprocessor, not the kernel
            blank(chars, m.start(), m.end())
    masked = "".join(chars)
    for m in re.finditer(r"__attribute__\s*\(", masked):  # reqd_work_group_size must match the host's launch
        end = closing(masked, m.end() - 1, "()")
        blank(chars, m.start(), end + 1 if end >= 0 else m.end())
    return "".join(chars)


def type_names(text: str) -> set[str]:
    """The struct and typedef names the file and the shared headers declare (``Boid* b`` is no product)."""
    sources = [text] + [p.read_text() for p in sorted((KERNELS / "include").glob("*.h"))]
    names = set()
    for source in sources:
        names.update(re.findall(r"typedef\s+struct\s*\w*\s*\{.*?\}\s*(\w+)\s*;", source, re.S))
        names.update(re.findall(r"typedef\s+[\w\s]+?\s(\w+)\s*;", source))
        names.update(re.findall(r"struct\s+(\w+)", source))
    return names


def bumped(number: str) -> str:
    """A numeric literal changed a little: integer k -> k + 1, float v -> 1.2 v (0 -> 0.1), suffix kept."""
    body, suffix = re.fullmatch(r"(0[xX][0-9a-fA-F]+|[\d.]+(?:[eE][+-]?\d+)?)([a-zA-Z]*)", number).groups()
    if body[:2] in ("0x", "0X"):
        return f"{int(body, 16) + 1:#x}{suffix}"
    if "." in body or "e" in body.lower() or suffix.lower() in ("f", "h"):
        value = float(body)
        new = f"{value * 1.2 if value else 0.1:.6g}"
        return (new if "." in new or "e" in new else new + ".0") + suffix
    return f"{int(body) + 1}{suffix}"


def sites(text: str) -> list[Mutant]:
    """Every candidate mutation of a kernel file, in file order (so a seeded draw from them is reproducible)."""
    masked = code_only(text)
    types = type_names(text)
    tokens = [(m.lastgroup, m[0], m.start()) for m in TOKEN.finditer(masked) if m.lastgroup != "space"]

    def is_type(tok: str) -> bool:
        return tok in types or bool(BUILTIN_TYPE.fullmatch(tok))

    def operand_end(i: int) -> bool:
        """Token i ends an operand: a following `*` multiplies, a following `[` indexes."""
        kind, tok, _ = tokens[i] if i >= 0 else ("op", "", 0)
        if kind == "name":
            return not is_type(tok) and tok not in NOT_OPERANDS
        return kind == "number" or tok in (")", "]")

    opening, stack = {}, []  # the `[` of each `]`, by token index
    for i, (_, tok, _) in enumerate(tokens):
        if tok == "[":
            stack.append(i)
        elif tok == "]" and stack:
            opening[i] = stack.pop()

    def declared(i: int) -> bool:
        """The `[` at token i gives an array's size in a declaration (`float own[6][LANES]`), not an index."""
        while i >= 1 and tokens[i - 1][1] == "]" and i - 1 in opening:
            i = opening[i - 1]
        return i >= 2 and tokens[i - 1][0] == "name" and is_type(tokens[i - 2][1])

    found = []
    for i, (kind, tok, start) in enumerate(tokens):
        if kind == "number":
            found.append(Mutant(start, start + len(tok), bumped(tok), "constant"))
        elif tok in SWAPS:
            found.append(Mutant(start, start + len(tok), SWAPS[tok], "operator"))
        elif tok == "*" and operand_end(i - 1):
            found.append(Mutant(start, start + 1, "/", "operator"))
        elif tok == "*=":
            found.append(Mutant(start, start + 2, "/=", "operator"))
        elif tok == "[" and operand_end(i - 1) and not declared(i):
            # an index (not the size in a declaration `float tile[N]`): off by one either way
            end = closing(masked, start, "[]")
            if end > start + 1:
                inner = text[start + 1 : end]
                for sign in "+-":
                    found.append(Mutant(start, end + 1, f"[({inner}) {sign} 1]", "index"))
        elif tok in ("barrier", "work_group_barrier") and masked[start + len(tok) :].lstrip().startswith("("):
            end = closing(masked, masked.index("(", start), "()")
            if end > 0:
                found.append(Mutant(start, end + 1, "", "barrier"))
    for m in found:
        m.line = text.count("\n", 0, m.start) + 1
        m.before_text, m.after_text = describe(text, m)
    return found


def describe(text: str, m: Mutant) -> tuple[str, str]:
    """(before, after): the changed text with a few words either side, on one line."""
    line_start = text.rfind("\n", 0, m.start) + 1
    line_end = text.find("\n", m.end)
    line_end = len(text) if line_end < 0 else line_end
    a, b = max(line_start, m.start - 20), min(line_end, m.end + 20)
    while a > line_start and not text[a - 1].isspace():  # whole words at both ends
        a -= 1
    while b < line_end and not text[b].isspace():
        b += 1
    for comment in ("//", "/*"):  # a comment after the change is no part of it
        found = text.find(comment, m.end, b)
        b = found if found >= 0 else b
    before = text[a:b]
    after = text[a : m.start] + m.after + text[m.end : b]
    return " ".join(before.split()), " ".join(after.split())


def apply(text: str, m: Mutant) -> str:
    return text[: m.start] + m.after + text[m.end :]


def drawn(text: str, seed: int) -> list[Mutant]:
    """Every site in a seeded random order: the first MUTANTS are run, the next ones replace those that do not
    build. The order depends only on the file's text and the seed, so a rerun draws the same mutants."""
    candidates = sites(text)
    return random.Random(seed).sample(candidates, len(candidates))


# }}}

# {{{ running


@dataclass
class Result:
    index: int  # the mutant's place in the draw
    line: int
    kind: str
    before: str
    after: str
    status: str  # killed, timeout (counted as killed), survived, stillborn (does not build), error (pytest failed)
    seconds: float
    failed: str = ""  # the first test that failed (killed), or the last lines of output (error)


_running: set[subprocess.Popen] = set()
_lock = threading.Lock()


def stop_running() -> None:
    """Kill the test runs in flight, each with its process group (they run in sessions of their own, so Ctrl-C
    reaches only this script)."""
    with _lock:
        for proc in _running:
            try:
                os.killpg(proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass


def run_tests(
    folder: Path, stem: str, tests: list[str], timeout: float, threads: int, oclgrind: bool = False
) -> tuple[str, float, str]:
    """Run ``tests`` against the kernel folder ``folder``: (status, seconds, detail). ``oclgrind``: the tests marked
    oclgrind instead, on the simulator that reports reads and writes out of bounds and data races."""
    env = dict(os.environ, UGPCL_KERNELS=str(folder))
    if oclgrind:
        env["OCLGRIND_DATA_RACES"] = "1"
    if threads:  # several jobs share the cores: PoCL's pthread device would start one thread per core in each
        env["POCL_MAX_PTHREAD_COUNT"] = env["POCL_CPU_MAX_CU_COUNT"] = str(threads)  # PoCL < 5, and 5+'s name
    basetemp = folder.parent / "pytest"  # pytest's tmp_path of this run alone: parallel runs never share one
    args = [*PYTEST_ARGS[:-1], "oclgrind"] if oclgrind else PYTEST_ARGS
    cmd = [sys.executable, "-m", "pytest", *tests, *args, f"--basetemp={basetemp}"]
    t0 = time.monotonic()
    proc = subprocess.Popen(
        cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True
    )
    with _lock:
        _running.add(proc)
    try:
        out, _ = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:  # a mutant that loops forever: the tests did not pass, so it is killed
        os.killpg(proc.pid, signal.SIGKILL)  # the whole group: pytest and any `ugpcl` it started
        proc.communicate()
        return "timeout", time.monotonic() - t0, f"no result after {timeout:g} s"
    finally:
        with _lock:
            _running.discard(proc)
    seconds = time.monotonic() - t0
    if proc.returncode == 0 or (oclgrind and proc.returncode == 5):  # 5: no oclgrind test in these files
        return "survived", seconds, ""
    if f"{stem}.cl: build failed" in out:  # ugpcl.runtime.BuildError of the mutated file: it never ran
        return "stillborn", seconds, POISON if POISON in out else ""
    if proc.returncode in (1, 2) or proc.returncode < 0:  # test failed, collection error, or crashed (a signal)
        first = re.search(r"^(?:FAILED|ERROR) (\S+)", out, re.M)
        crash = f"a crash (signal {-proc.returncode})" if proc.returncode < 0 else f"exit status {proc.returncode}"
        return "killed", seconds, first[1] if first else crash
    return "error", seconds, "\n".join(out.strip().splitlines()[-5:])  # pytest's own trouble: no verdict


def run_one(
    snapshot: Path, stem: str, source: str, tests: list[str], timeout: float, threads: int, oclgrind: bool = False
):
    """Copy the kernel folder, write ``source`` as ``<stem>.cl`` there and run the tests on it; a survivor, with
    ``oclgrind``, runs the chapter's Oclgrind tests too (a guard loosened by one reads past a buffer there)."""
    with tempfile.TemporaryDirectory(prefix=f"ugpcl-mutate-{stem}-") as tmp:
        folder = Path(tmp) / "clkernels"
        shutil.copytree(snapshot, folder)
        (folder / f"{stem}.cl").write_text(source)
        status, seconds, detail = run_tests(folder, stem, tests, timeout, threads)
        if status == "survived" and oclgrind:
            status, more, detail = run_tests(folder, stem, tests, timeout, threads, oclgrind=True)
            seconds += more
            detail = f"{detail} (Oclgrind)" if status == "killed" else detail
        return status, seconds, detail


def line_of(r: Result, stem: str) -> str:
    """One mutant's line: where, what, the verdict and its time, and what killed it (or pytest's trouble)."""
    detail = {
        "killed": f"  by {r.failed.rpartition('::')[2]}",
        "error": "\n      " + r.failed.replace("\n", "\n      "),
    }.get(r.status, "")
    return f"  #{r.index:<3} {stem}.cl:{r.line:<4} {r.before} -> {r.after}   {r.status} {r.seconds:.1f} s{detail}"


def mutate_chapter(stem: str, snapshot: Path, args) -> dict:
    chapter, stem = stem, BORROWED.get(stem, stem)
    text = (snapshot / f"{stem}.cl").read_text()
    tests = chapter_tests(chapter)
    order = drawn(text, args.seed)
    report = {"chapter": chapter, "file": f"clkernels/{stem}.cl", "tests": tests, "candidates": len(order)}
    print(f"{chapter}: {stem}.cl, {len(order)} candidate sites, tests: {' '.join(tests)}", flush=True)
    threads = args.threads or (max(1, (os.cpu_count() or 1) // args.jobs) if args.jobs > 1 else 0)

    def run(source: str, oclgrind: bool = False) -> tuple[str, float, str]:
        return run_one(snapshot, stem, source, tests, args.timeout, threads, oclgrind)

    if not args.no_checks:
        # The tests must pass on an unmutated copy (else every mutant is "killed") and must fail to build a copy
        # that cannot compile (else they do not read UGPCL_KERNELS, and no mutant would be seen).
        status, seconds, detail = run(text)
        print(f"  check: unmutated copy {'passes' if status == 'survived' else status} ({seconds:.1f} s)", flush=True)
        report["baseline_seconds"] = round(seconds, 1)
        if status != "survived":
            report["check_failed"] = f"the tests fail on an unmutated copy ({status}: {detail})"
            print(f"  {report['check_failed']}; chapter skipped", flush=True)
            return report
        status, seconds, detail = run(f'#error "{POISON}"\n{text}')
        ok = status == "stillborn" and detail == POISON
        print(
            f"  check: a copy that cannot build is {'seen' if ok else 'NOT seen: ' + status} ({seconds:.1f} s)",
            flush=True,
        )
        if not ok:
            report["check_failed"] = f"the tests do not build {stem}.cl from UGPCL_KERNELS ({status})"
            print(f"  {report['check_failed']}; chapter skipped", flush=True)
            return report

    results: list[Result] = []
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        pending, next_index = {}, 0
        try:
            # Only as many in flight as are still needed: the mutants run are the first MUTANTS of the draw that
            # build, whatever order the jobs finish in.
            only = list(args.only or [])
            while True:
                built = sum(r.status != "stillborn" for r in results)
                while only:  # --only: these places of the draw, no others
                    next_index = only.pop(0)
                    m = order[next_index]
                    pending[pool.submit(run, apply(text, m), args.oclgrind)] = (next_index, m)
                while not args.only and next_index < len(order) and built + len(pending) < args.mutants:
                    m = order[next_index]
                    pending[pool.submit(run, apply(text, m), args.oclgrind)] = (next_index, m)
                    next_index += 1
                if not pending:
                    break
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                for future in done:
                    index, m = pending.pop(future)
                    status, seconds, detail = future.result()
                    r = Result(index, m.line, m.kind, m.before_text, m.after_text, status, round(seconds, 1), detail)
                    results.append(r)
                    print(line_of(r, stem), flush=True)
        except KeyboardInterrupt:  # queued mutants never start; running ones are stopped in main()
            pool.shutdown(wait=False, cancel_futures=True)
            stop_running()
            raise

    results.sort(key=lambda r: r.index)
    count = {s: sum(r.status == s for r in results) for s in ("killed", "timeout", "survived", "stillborn", "error")}
    total = count["killed"] + count["timeout"] + count["survived"]
    killed = count["killed"] + count["timeout"]
    report.update(
        count,
        total=total,
        kill_rate=round(100 * killed / total, 1) if total else None,
        mutants=[asdict(r) for r in results],
    )
    rate = f"{100 * killed / total:.0f}%" if total else "-"
    print(
        f"{chapter}: killed {killed}/{total} ({rate}; {count['timeout']} of them by timeout), survived "
        f"{count['survived']}, stillborn {count['stillborn']} (redrawn), errors {count['error']}"
        + (f"; only {total} of {args.mutants} built" if total < args.mutants else ""),
        flush=True,
    )
    return report


# }}}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    stems = sorted([p.stem for p in KERNELS.glob("*.cl")] + list(BORROWED))
    parser.add_argument(
        "--chapter",
        default="boids",
        help=f"a kernel file's stem, several joined by commas, or all ({', '.join(stems)})",
    )
    parser.add_argument("--mutants", type=int, default=15, help="mutants that build, per chapter (default 15)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the draw (default 0)")
    parser.add_argument("--jobs", type=int, default=1, help="mutants tested at once (default 1)")
    parser.add_argument(
        "--threads", type=int, default=0, help="PoCL threads per test run (default: the cores / JOBS when JOBS > 1)"
    )
    parser.add_argument("--timeout", type=float, default=300, help="seconds per test run; past it, killed (300)")
    parser.add_argument("--json", type=Path, help="write the results here (for the table of docs/testing.md)")
    parser.add_argument("--list", action="store_true", help="print the first MUTANTS drawn; run nothing")
    parser.add_argument(
        "--only", type=lambda t: [int(i) for i in t.split(",")], help="run only these places of the draw (0,7,9)"
    )
    parser.add_argument(
        "--oclgrind", action="store_true", help="a survivor also runs the chapter's Oclgrind tests (much slower)"
    )
    parser.add_argument("--no-checks", action="store_true", help="skip the unmutated and unbuildable copies' runs")
    args = parser.parse_args(argv)
    chosen = stems if args.chapter == "all" else args.chapter.split(",")
    unknown = [s for s in chosen if s not in stems]
    if unknown or args.mutants < 1 or args.jobs < 1:
        parser.error(f"no kernel file {', '.join(unknown)}.cl" if unknown else "--mutants and --jobs must be >= 1")

    if args.list:
        for chapter in chosen:
            stem = BORROWED.get(chapter, chapter)
            order = drawn((KERNELS / f"{stem}.cl").read_text(), args.seed)
            print(f"{chapter}: {stem}.cl, {len(order)} candidate sites; the first {args.mutants} (seed {args.seed}):")
            for index, m in enumerate(order[: args.mutants]):
                print(f"  #{index:<3} {stem}.cl:{m.line:<4} {m.kind:<9} {m.before_text} -> {m.after_text}")
        return 0

    reports = []
    # One snapshot of clkernels/ for the whole run: edits made to the tree meanwhile do not mix into it.
    with tempfile.TemporaryDirectory(prefix="ugpcl-mutate-") as tmp:
        snapshot = Path(tmp) / "clkernels"
        shutil.copytree(KERNELS, snapshot, ignore=shutil.ignore_patterns("__pycache__"))
        try:
            for stem in chosen:
                reports.append(mutate_chapter(stem, snapshot, args))
        except KeyboardInterrupt:
            stop_running()
            print("mutate: interrupted", file=sys.stderr)
            return 130
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"seed": args.seed, "mutants": args.mutants, "chapters": reports}, indent=1))
    return 1 if any("check_failed" in r for r in reports) else 0


if __name__ == "__main__":
    sys.exit(main())
