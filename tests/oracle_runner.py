"""Run Knitout files on the independent virtual knitting machine and report as JSON.

This script is run by the ORACLE's interpreter, never by knitc's:

    .venv-oracle/bin/python tests/oracle_runner.py [--timeout S] FILE.k [FILE2.k ...]

`.venv-oracle` (``make oracle-venv``) holds knitout-interpreter 0.1.8, virtual-knitting-machine
0.0.31 and knit-graphs 0.1.4, an independent Knitout implementation (see
shared/research/peers-and-oracles.md §1.3-1.4). knitc itself never imports them; pytest talks
to this script through ``tests/oracle.py``.

Every file is run on a fresh machine built to knitc's target (a Shima SWG091N2, 15 gauge,
540 needles per bed, 10 carriers, racking limited to 4) in the strictest violation policy.
The Knitout header of the file is checked against that target, never used to build the
machine. One JSON document goes to stdout::

    {"runner": {...versions...}, "reports": [{...one per file, in order...}]}

Each report holds ``ok`` (ran to the end without an error), ``errors`` and ``warnings`` (type,
message, 1-based line), the end state (loops left on needles, active carriers, the hook),
the number of carriage passes and of no-op instructions, the lines that were stripped before
the run, and the time taken. When a file stops on an error the state fields describe the
machine at the point where it stopped.

With ``--fabric`` each report also holds the knitted fabric as the machine's knit graph saw
it (``fabric``), for comparing with the design (``tests/fabric.py``)::

    {"loops": [[id, line, needle, yarn, [parent, ...], [pull, ...]], ...],
     "yarns": [[carrier, [loop, ...]], ...]}

``line`` is the 1-based line of the instruction that formed the loop, ``needle`` where it was
formed (``f12``), ``yarn`` an index into ``yarns``; parents are loop ids in stacking order,
each with the pull direction of its stitch edge (1 = back to front, a knit seen from the
front bed; 0 = front to back).

The exit code is 0 whatever happened to the files: the caller judges. Only a bad command line
exits non-zero. Anything the interpreter prints goes to stderr so that stdout stays JSON.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import platform
import re
import signal
import sys
import time
import traceback
import warnings
from importlib import metadata
from pathlib import Path

# --------------------------------------------------------------------------------------------
# The target machine (docs/architecture.md §4, shared/research/knitout-and-dat.md §4).
# --------------------------------------------------------------------------------------------
TARGET_MACHINE = "SWG091N2"
TARGET_GAUGE = 15
TARGET_NEEDLES = 540
TARGET_CARRIERS = 10
TARGET_MAX_RACK = 4

# --------------------------------------------------------------------------------------------
# Lines the oracle cannot read and that are stripped (replaced by an empty line, so that line
# numbers stay those of the file) before the run. Each kind is counted in the report under
# "stripped". Only lines that change neither the loops on the needles nor which carriers are
# in are stripped; anything else the oracle cannot read stays in and is reported as an error
# (with a "hint" when it is a known limitation of the oracle rather than a fault of the file).
#
#   width_header     ";;Width: N". The grammar has the rule but no parser action for it, so
#                    the line is rejected as incomplete (research §1.4, bug 1).
#   x_header         ";;X-...: ..." extension headers: not in the grammar.
#   unknown_header   any other ";;Name: value" header the grammar does not know (it knows
#                    Machine, Gauge, Carriers, Position, Yarn-N). The spec says readers warn
#                    and go on.
#   yarn_header      ";;Yarn-N: ..." whose value is not in the "plies-weight colour" form,
#                    the only form the grammar takes. Descriptive only.
#   source_comment   ";!source: ..." comments (spec v0.6): the grammar reads ";!" only as the
#                    start of the magic line.
#   x_extension      "x-..." extension instructions (x-stitch-number, x-speed-number,
#                    x-presser-mode, x-vis-color, ...): not in the grammar (research §1.4,
#                    limitation 3). Machine settings, no loop effect.
#   stitch           "stitch L T": not in the grammar; a yarn-length setting, no loop effect.
#   kick             "kick D N CS": the grammar has the rule but never reaches it (§1.4, 3).
#                    It only moves carriers.
#   amiss            "amiss N" and "tuck D N" with no carriers: not in the grammar. The
#                    needle rises and falls; no loop is made or moved.
#
# Not stripped, reported as errors with a hint: negative needle numbers, "in/out/inhook/
# outhook/releasehook" with more than one carrier (the grammar takes one), "knit D N" and
# "split D N N2" with no carriers (write "drop N" and "xfer N N2"), upper-case needle names
# (the grammar ignores case but reads "F3" as b3: refused here rather than run wrongly).
# --------------------------------------------------------------------------------------------
_HEADER = re.compile(r"^;;([A-Za-z][\w-]*):\s?(.*)$")
_KNOWN_HEADERS = {"machine", "gauge", "carriers", "position"}
_YARN_OK = re.compile(r"^-?\d+-\d+\s+[A-Za-z_]\w*\s*$")
_OPCODE = re.compile(r"^\s*([A-Za-z][\w-]*)\b(.*)$")
_NO_CARRIER_TUCK = re.compile(r"^\s*tuck\s+[+-]\s+\S+\s*$", re.IGNORECASE)

MAX_PARSE_ERRORS = 20

STRIP_KINDS = (
    "width_header",
    "x_header",
    "unknown_header",
    "yarn_header",
    "source_comment",
    "x_extension",
    "stitch",
    "kick",
    "amiss",
)


def _code_part(line: str) -> str:
    """The instruction part of a body line: everything before the first ';'."""
    return line.split(";", 1)[0].strip()


def strip_kind(line: str) -> str | None:
    """The STRIP_KINDS entry `line` belongs to, or None if it is passed on unchanged."""
    s = line.strip()
    if s.startswith(";;"):
        m = _HEADER.match(s)
        if m is None:
            return None  # a ";;" comment that is no header: the grammar reads it as a comment
        name, value = m.group(1).lower(), m.group(2)
        if name == "width":
            return "width_header"
        if name.startswith("x-"):
            return "x_header"
        if name.startswith("yarn-"):
            return None if _YARN_OK.match(value) else "yarn_header"
        return None if name in _KNOWN_HEADERS else "unknown_header"
    if s.startswith(";!source:"):
        return "source_comment"
    code = _code_part(s)
    m = _OPCODE.match(code)
    if m is None:
        return None
    op = m.group(1).lower()
    if op.startswith("x-"):
        return "x_extension"
    if op == "stitch":
        return "stitch"
    if op == "kick":
        return "kick"
    if op == "amiss" or _NO_CARRIER_TUCK.match(code):
        return "amiss"
    return None


_CARRIER_OPS = {"in", "inhook", "out", "outhook", "releasehook"}


def limitation_hint(line: str) -> str | None:
    """Why the oracle cannot read `line` when that is its own limitation, else None."""
    code = _code_part(line)
    tokens = code.split()
    if not tokens:
        return None
    op = tokens[0].lower()
    if op in _CARRIER_OPS and len(tokens) > 2:
        return (
            f"the oracle's grammar takes one carrier per '{op}'; this line names {len(tokens) - 1}"
        )
    if any(re.fullmatch(r"[fb]s?-\d+", t) for t in tokens[1:]):
        return "the oracle's grammar has no negative needle numbers"
    if any(re.fullmatch(r"[fbFB][sS]?\d+", t) and t != t.lower() for t in tokens[1:]):
        return "upper-case needle names: the oracle would read them as back-bed needles"
    if op == "knit" and len(tokens) == 3:
        return "'knit D N' with no carriers (a drop) is not in the oracle's grammar: write 'drop N'"
    if op == "split" and len(tokens) == 4:
        return "'split D N N2' with no carriers is not in the oracle's grammar: write 'xfer N N2'"
    if op == "pause" and len(tokens) > 1:
        return "'pause' takes no arguments in the oracle's grammar"
    return None


def check_header(lines: list[str]) -> list[dict]:
    """Errors for a missing magic line or Carriers header (both required by the spec, and by
    the Shima backend), and for header lines that contradict the target machine: the oracle is
    built to the target, not to the header, so a contradicting header would make its verdict
    meaningless."""
    want = {
        "machine": TARGET_MACHINE,
        "gauge": str(TARGET_GAUGE),
        "carriers": " ".join(str(c) for c in range(1, TARGET_CARRIERS + 1)),
    }
    errors = []
    if not lines or not re.match(r"^;!knitout-\d+\s*$", lines[0]):
        first = lines[0] if lines else None
        errors.append(
            _error("header", "Missing_Magic_Line", "line 1 must be ';!knitout-2'", 0, first)
        )
    seen = set()
    for i, line in enumerate(lines):
        s = line.strip()
        if not s:
            continue
        if not s.startswith(";"):
            break  # the header ends at the first instruction
        m = _HEADER.match(s)
        if m is None:
            continue
        name, value = m.group(1).lower(), " ".join(m.group(2).split())
        seen.add(name)
        if name in want and value != want[name]:
            errors.append(
                _error(
                    "header",
                    "Header_Mismatch",
                    f"';;{m.group(1)}: {value}' but the oracle runs a {TARGET_MACHINE}, gauge "
                    f"{TARGET_GAUGE}, carriers '{want['carriers']}'",
                    i,
                    line,
                )
            )
    if "carriers" not in seen:
        errors.append(
            _error(
                "header",
                "Missing_Carriers_Header",
                f"no ';;Carriers: {want['carriers']}' header before the first instruction",
                None,
                None,
            )
        )
    return errors


_RACK = re.compile(r"^\s*rack\s+(-?[0-9.]+)\s*$", re.IGNORECASE)
_XFER = re.compile(
    r"^\s*(?:xfer\s+(\S+)\s+(\S+)|split\s+[+-]\s+(\S+)\s+(\S+)(?:\s+\S+)*)\s*$", re.IGNORECASE
)
_NEEDLE = re.compile(r"^([fb])s?(-?\d+)$")


def check_xfer_alignment(lines: list[str]) -> list[dict]:
    """Errors for xfer/split whose two needles are not aligned at the racking in force, for
    target needles at position 0 or 1 only. The oracle compares a bool with the target's
    position in its alignment check, so for those targets any racking passes (research §1.4,
    bug 2); every other target is checked by the oracle itself. At racking R back needle k
    faces front needle k + R."""
    rack = 0.0
    errors = []
    for i, line in enumerate(lines):
        code = _code_part(line)
        if not code:
            continue
        m = _RACK.match(code)
        if m:
            with contextlib.suppress(ValueError):
                rack = float(m.group(1))
            continue
        m = _XFER.match(code)
        if not m:
            continue
        src, dst = (m.group(1), m.group(2)) if m.group(1) else (m.group(3), m.group(4))
        ms, md = _NEEDLE.match(src), _NEEDLE.match(dst)
        if not ms or not md or ms.group(1) == md.group(1):
            continue  # unreadable, or same bed: the oracle reports those itself
        if int(md.group(2)) not in (0, 1):
            continue
        front, back = (ms, md) if ms.group(1) == "f" else (md, ms)
        if int(back.group(2)) + rack != int(front.group(2)):
            errors.append(
                _error(
                    "machine",
                    "Misaligned_Xfer",
                    f"{src} and {dst} are not aligned at racking {rack:g} (found by the runner: "
                    f"the oracle misses misaligned transfers onto needle 0 or 1)",
                    i,
                    line,
                )
            )
    return errors


def misaligned_before(misaligned: list[dict], index: int | None) -> list[dict]:
    """The runner's alignment errors that come before the line the oracle stopped on."""
    return [e for e in misaligned if index is None or e["line"] <= index]


def _error(kind: str, type_: str, message: str, index: int | None, source: str | None) -> dict:
    message = " ".join(message.split())
    if message.startswith(type_ + ":"):  # the oracle's exceptions repeat their class name
        message = message[len(type_) + 1 :].lstrip()
    e = {
        "kind": kind,
        "type": type_,
        "message": message,
        "line": None if index is None else index + 1,
        "source": None if source is None else source.rstrip("\r\n"),
    }
    hint = limitation_hint(source) if (source and kind == "parse") else None
    if hint:
        e["hint"] = hint
    return e


class _Timeout(BaseException):
    """Raised by the alarm. A BaseException, so that the interpreter's own `except Exception`
    wrappers cannot swallow it or dress it up as a machine error."""


def _on_alarm(signum, frame):
    raise _Timeout()


# --------------------------------------------------------------------------------------------
# The run itself.
# --------------------------------------------------------------------------------------------
class Oracle:
    """Everything from the oracle packages, imported and set up once for many files."""

    def __init__(self) -> None:
        from knitout_interpreter.knitout_errors.Knitout_Error import Knitout_Machine_StateError
        from knitout_interpreter.knitout_execution import Knitout_Executer
        from knitout_interpreter.knitout_execution_structures.Knitout_Knitting_Machine import (
            Knitout_Knitting_Machine,
            Knitout_Machine_Specification,
        )
        from knitout_interpreter.knitout_language.Knitout_Parser import Knitout_Parser
        from knitout_interpreter.knitout_operations.Knitout_Line import Knitout_Line, Knitout_No_Op

        self.StateError = Knitout_Machine_StateError
        self.Machine = Knitout_Knitting_Machine
        self.Line = Knitout_Line
        self.NoOp = Knitout_No_Op
        self.spec = Knitout_Machine_Specification(
            gauge=TARGET_GAUGE,
            carrier_count=TARGET_CARRIERS,
            needle_count=TARGET_NEEDLES,
            maximum_rack=TARGET_MAX_RACK,
        )
        # The grammar tables are built once here, not once per file.
        self.parser = Knitout_Parser()

        class Executer(Knitout_Executer):
            """Records the instruction in hand, so that warnings get a line number, and keeps
            hold of itself when execution stops on an error (it all runs in __init__)."""

            current_line: int | None = None
            last: Knitout_Executer | None = None
            born: dict[int, int] | None = None
            """loop id -> the 0-based line that formed it (only when the fabric is asked for)."""

            def test_and_organize_instructions(self) -> None:
                type(self).last = self
                super().test_and_organize_instructions()

            def _process_next_instruction(self, instruction) -> None:
                self._note(instruction)
                super()._process_next_instruction(instruction)

            def _execute_and_add_instruction(self, instruction) -> None:
                self._note(instruction)
                born = type(self).born
                if born is None:
                    super()._execute_and_add_instruction(instruction)
                    return
                kg = self.knitting_machine.knit_graph
                before = -1 if kg.last_loop is None else kg.last_loop.loop_id
                super()._execute_and_add_instruction(instruction)
                after = -1 if kg.last_loop is None else kg.last_loop.loop_id
                line = type(self).current_line
                for loop_id in range(before + 1, after + 1):
                    born[loop_id] = -1 if line is None else line

            @classmethod
            def _note(cls, instruction) -> None:
                if getattr(instruction, "has_line_number", False):
                    cls.current_line = instruction.original_line_number

        self.Executer = Executer

    def parse(self, lines: list[str]) -> list:
        """Parse line by line. The oracle's own numbering counts parsed lines only (blank lines
        and comments shift it), so every parsed line is stamped with its index in the file."""
        import parglare.exceptions

        codes, errors = [], []
        for i, line in enumerate(lines):
            if not line.strip():
                continue
            hint = limitation_hint(line)
            if hint and hint.startswith("upper-case"):
                errors.append(_error("unsupported", "Unsupported_Needle_Name", hint, i, line))
                continue
            try:
                code = self.parser._parser.parse(line, extra=i)
            except parglare.exceptions.SyntaxError as e:
                errors.append(_error("parse", "Knitout_ParseError", _first_line(e), i, line))
                continue
            if code is None:
                continue
            if not isinstance(code, self.Line):
                errors.append(
                    _error(
                        "parse",
                        "Incomplete_Knitout_Line_Error",
                        "the line does not make a complete Knitout line",
                        i,
                        line,
                    )
                )
                continue
            code.set_line(i)  # the first set_line wins: later renumbering leaves it alone
            codes.append(code)
        if errors:  # every unreadable line is reported (up to MAX_PARSE_ERRORS), none is run
            raise _Stop(errors[:MAX_PARSE_ERRORS])
        return codes

    def run(self, path: str, timeout: float | None, fabric: bool = False) -> dict:
        t0 = time.perf_counter()
        report: dict = {
            "path": path,
            "ok": False,
            "errors": [],
            "warnings": [],
            "loops_left": None,
            "needles_with_loops": [],
            "carriers_active": [],
            "hook_in_use": None,
            "hooked_carrier": None,
            "carriage_passes": None,
            "no_ops": None,
            "knit_graph": None,
            "stripped": {},
            "lines": 0,
            "elapsed_s": 0.0,
        }
        machine = None
        self.Executer.last = None
        self.Executer.current_line = None
        self.Executer.born = {} if fabric else None
        lines: list[str] = []
        misaligned: list[dict] = []

        def on_warning(message, category, filename, lineno, file=None, line=None):
            w = message if isinstance(message, Warning) else category(str(message))
            text = " ".join(str(w).split())
            name = type(w).__name__
            if text.startswith(name):
                text = text[len(name) :].lstrip(": ").strip()
            cur = self.Executer.current_line
            report["warnings"].append(
                {"type": name, "message": text, "line": None if cur is None else cur + 1}
            )

        if timeout:
            signal.signal(signal.SIGALRM, _on_alarm)
            signal.setitimer(signal.ITIMER_REAL, timeout)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("always")
                warnings.showwarning = on_warning
                try:
                    text = Path(path).read_text(encoding="utf-8")
                except (OSError, UnicodeDecodeError) as e:
                    raise _Stop(_error("io", type(e).__name__, str(e), None, None)) from None
                lines = text.splitlines()
                report["lines"] = len(lines)
                kept = []
                for line in lines:
                    kind = strip_kind(line)
                    if kind is None:
                        kept.append(line)
                    else:
                        report["stripped"][kind] = report["stripped"].get(kind, 0) + 1
                        kept.append("")
                header_errors = check_header(lines)
                if header_errors:
                    report["errors"].extend(header_errors)
                    raise _Stop(None)
                codes = self.parse(kept)
                # Checked apart from the oracle, which misses them (see check_xfer_alignment);
                # reported after the run so that the oracle's own findings come too.
                misaligned = check_xfer_alignment(kept)
                machine = self.Machine(machine_specification=self.spec)
                self.Executer(codes, machine)
                report["ok"] = not misaligned
                report["errors"].extend(misaligned)
        except _Stop as stop:
            report["errors"].extend(stop.errors)
        except _Timeout:
            cur = self.Executer.current_line
            report["errors"].append(
                _error(
                    "timeout",
                    "Timeout",
                    f"stopped after {timeout} s",
                    cur,
                    lines[cur] if cur is not None and cur < len(lines) else None,
                )
            )
        except self.StateError as e:
            report["errors"].extend(misaligned_before(misaligned, e.line_number))
            idx = e.line_number
            inner = e.error
            report["errors"].append(
                _error(
                    "machine",
                    type(inner).__name__,
                    str(inner),
                    idx,
                    lines[idx] if idx is not None and idx < len(lines) else None,
                )
            )
        except Exception as e:  # anything else the interpreter throws: report, never crash
            cur = self.Executer.current_line
            err = _error(
                "internal",
                type(e).__name__,
                str(e) or repr(e),
                cur,
                lines[cur] if cur is not None and cur < len(lines) else None,
            )
            err["traceback"] = traceback.format_exc(limit=-4).splitlines()[-8:]
            report["errors"].append(err)
        finally:
            if timeout:
                signal.setitimer(signal.ITIMER_REAL, 0)
        with contextlib.suppress(Exception):
            self._end_state(report, machine, self.Executer.last)
        if fabric and machine is not None:
            report["fabric"] = self._fabric(machine, self.Executer.born or {})
        report["elapsed_s"] = round(time.perf_counter() - t0, 4)
        return report

    def _end_state(self, report: dict, machine, executer) -> None:
        if executer is not None:
            report["carriage_passes"] = executer.execution_time
            report["no_ops"] = sum(isinstance(x, self.NoOp) for x in executer.executed_instructions)
        if machine is None:
            return
        needles = machine.all_loops() + machine.all_slider_loops()
        report["loops_left"] = sum(len(n.held_loops) for n in needles)
        report["needles_with_loops"] = [str(n) for n in needles]
        cs = machine.carrier_system
        report["carriers_active"] = sorted(int(c) for c in cs.active_carriers)
        report["hook_in_use"] = cs.hooked_carrier is not None
        report["hooked_carrier"] = None if cs.hooked_carrier is None else int(cs.hooked_carrier)
        with contextlib.suppress(Exception):
            kg = machine.knit_graph
            report["knit_graph"] = {"loops": kg.loop_count, "stitches": kg.edge_count}

    @staticmethod
    def _fabric(machine, born: dict[int, int]) -> dict:
        """The knit graph as plain data (see the module docstring): every loop with the
        line that formed it, its needle, its yarn and its parents, and every yarn in order."""
        from knit_graphs.Pull_Direction import Pull_Direction

        kg = machine.knit_graph
        yarns = sorted(kg.yarns, key=lambda y: min((lp.loop_id for lp in y), default=-1))
        yarn_of = {}
        out_yarns = []
        for k, y in enumerate(yarns):
            ids = [lp.loop_id for lp in y]
            for i in ids:
                yarn_of[i] = k
            carrier = getattr(getattr(y, "carrier", None), "carrier_id", None)
            out_yarns.append([None if carrier is None else int(carrier), ids])
        loops = []
        for lp in kg.sorted_loops:
            line = born.get(lp.loop_id, -1)
            needle = lp.needle_history[0] if getattr(lp, "needle_history", None) else None
            parents = [p.loop_id for p in lp.parent_loops]
            pulls = [
                int(kg.get_pull_direction(p, lp) is Pull_Direction.BtF) for p in lp.parent_loops
            ]
            loops.append(
                [
                    lp.loop_id,
                    line + 1 if line >= 0 else None,
                    None if needle is None else str(needle),
                    yarn_of.get(lp.loop_id),
                    parents,
                    pulls,
                ]
            )
        return {"loops": loops, "yarns": out_yarns}


class _Stop(Exception):
    """Ends one file's run with an already-formatted error (or None)."""

    def __init__(self, errors: dict | list[dict] | None) -> None:
        super().__init__()
        self.errors = [] if errors is None else [errors] if isinstance(errors, dict) else errors


def _first_line(e: BaseException) -> str:
    """parglare's syntax errors carry a multi-line context picture; keep the message line."""
    text = str(e).strip()
    return text.splitlines()[0] if text else type(e).__name__


def _versions() -> dict:
    out = {"python": platform.python_version()}
    for dist in ("knitout-interpreter", "virtual-knitting-machine", "knit-graphs", "parglare"):
        try:
            out[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            out[dist] = None
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("files", nargs="+", metavar="FILE.k")
    ap.add_argument("--timeout", type=float, default=None, help="seconds allowed per file")
    ap.add_argument(
        "--fabric",
        action="store_true",
        help="also report the knit graph of each file (loops, parents, yarns)",
    )
    args = ap.parse_args(argv)

    real_stdout = sys.stdout
    result: dict = {"runner": _versions(), "reports": []}
    with contextlib.redirect_stdout(sys.stderr):  # keep stdout for the JSON alone
        t0 = time.perf_counter()
        try:
            oracle = Oracle()
        except Exception as e:  # the oracle itself cannot start: report it for every file
            err = _error("internal", type(e).__name__, f"oracle failed to start: {e}", None, None)
            result["reports"] = [
                {"path": f, "ok": False, "errors": [err], "warnings": []} for f in args.files
            ]
        else:
            result["runner"]["startup_s"] = round(time.perf_counter() - t0, 4)
            for f in args.files:
                result["reports"].append(oracle.run(f, args.timeout, args.fabric))
    json.dump(result, real_stdout)
    real_stdout.write("\n")
    real_stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
