"""A design is untrusted input (docs/security.md): what it may read, and that nothing it
names can block, flood or leak.

Imports and images may read only regular files below the design's folder and the
`--include` folders; a path that leads out (absolute, `..`, a symlink) is E226 at the
string, and no message quotes a file that is not a design. Each case runs the CLI
in-process, as a CI job compiling someone's design would.
"""

from __future__ import annotations

import os
import re
import struct
import zlib
from pathlib import Path

import pytest

from knitc import access
from knitc.cli import main
from knitc.driver import compile_file

TUBE = "tube a { length: 4 width: 4 }\nstart a.bottom\n"
SECRET = "root:x:0:0:secret-line"
LACE = "pattern lace() { set P where all() }\n"


def check(capsys, *argv: str) -> tuple[int, str]:
    code = main(["check", *argv])
    return code, capsys.readouterr().err


@pytest.fixture
def tree(tmp_path: Path) -> Path:
    """proj/ (the design's folder), lib/ (a sibling), outside/ with a secret file."""
    for d in ("proj/sub", "lib", "outside"):
        (tmp_path / d).mkdir(parents=True)
    (tmp_path / "lib" / "lace.knit").write_text(LACE)
    (tmp_path / "proj" / "sub" / "lace.knit").write_text(LACE)
    (tmp_path / "outside" / "secret.knit").write_text(SECRET + "\n")
    (tmp_path / "outside" / "secret.txt").write_text(SECRET + "\n")
    return tmp_path


def design(tree: Path, *lines: str) -> str:
    path = tree / "proj" / "d.knit"
    path.write_text("".join(line + "\n" for line in lines) + TUBE)
    return str(path)


def only_error(err: str) -> tuple[str, str]:
    """(code, headline) of the one error in `err`."""
    heads = re.findall(r"error\[(E\d{3})\]: (.*)", err)
    assert len(heads) == 1, err
    return heads[0]


# ---- imports ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("target", "how"),
    [
        ("/etc/passwd", "an absolute path"),
        ("../../../../../../proc/self/environ", "`..` leads out"),
        ("../outside/secret.knit", "`..` leads out"),
        ("/nonexistent/x.knit", "an absolute path"),  # existence is not revealed either
    ],
)
def test_imports_outside_the_folders_are_refused_unread(tree, capsys, target, how):
    code, err = check(capsys, design(tree, f'import "{target}"'))
    assert code == 1
    assert only_error(err)[0] == "E226" and how in err
    assert SECRET not in err and "root:" not in err
    assert "--include DIR" in err


def test_a_symlink_out_of_the_folder_is_refused(tree, capsys):
    (tree / "proj" / "link.knit").symlink_to(tree / "outside" / "secret.knit")
    code, err = check(capsys, design(tree, 'import "link.knit"'))
    assert code == 1 and only_error(err)[0] == "E226" and "a symlink leads out" in err
    assert SECRET not in err


def test_a_path_through_dot_dot_that_stays_inside_is_fine(tree, capsys):
    assert check(capsys, design(tree, 'import "sub/../sub/lace.knit"'))[0] == 0


def test_include_folders_may_be_read(tree, capsys):
    path = design(tree, 'import "../lib/lace.knit"')
    assert only_error(check(capsys, path)[1])[0] == "E226"
    assert check(capsys, "--include", str(tree / "lib"), path)[0] == 0
    # the in-process API takes the same folders
    assert compile_file(path, include=[str(tree / "lib")]).ok
    assert not compile_file(path).ok


def test_an_include_that_is_not_a_folder_is_a_usage_error(tree, capsys):
    code, err = check(capsys, "--include", str(tree / "nope"), design(tree))
    assert code == 2 and "not a directory" in err


def test_an_imported_file_that_is_not_a_design_is_never_quoted(tree, capsys):
    (tree / "proj" / "notes.txt").write_text(SECRET + "\n")
    code, err = check(capsys, design(tree, 'import "notes.txt"'))
    assert code == 1 and only_error(err)[0] == "E226" and "is not a design" in err
    assert SECRET not in err


def test_an_import_that_is_not_utf8_is_not_quoted(tree, capsys):
    (tree / "proj" / "bin.knit").write_bytes(b"\xff\xfe" + SECRET.encode())
    code, err = check(capsys, design(tree, 'import "bin.knit"'))
    assert code == 1 and only_error(err) == ("E203", "cannot read `bin.knit`: it is not UTF-8 text")
    assert SECRET not in err


def test_an_import_of_a_fifo_does_not_block(tree, capsys):
    os.mkfifo(tree / "proj" / "pipe.knit")  # no writer: an open for reading would wait forever
    code, err = check(capsys, design(tree, 'import "pipe.knit"'))
    assert code == 1 and only_error(err) == (
        "E203",
        "`pipe.knit` is not a regular file (a device or FIFO)",
    )


def test_an_import_of_a_directory(tree, capsys):
    (tree / "proj" / "dir.knit").mkdir()
    code, err = check(capsys, design(tree, 'import "dir.knit"'))
    assert code == 1 and only_error(err) == ("E203", "`dir.knit` is a directory")


def test_an_import_larger_than_the_limit_is_refused(tree, capsys, monkeypatch):
    from knitc.frontend import definitions

    monkeypatch.setattr(definitions, "MAX_IMPORT_BYTES", 10)
    code, err = check(capsys, design(tree, 'import "sub/lace.knit"'))
    assert code == 1 and only_error(err)[0] == "E203"
    assert f"is {len(LACE)} bytes; knitc reads at most 10" in err


def test_stdlib_imports_are_unaffected(tree, capsys, monkeypatch):
    monkeypatch.chdir(tree / "outside")
    assert check(capsys, design(tree, "import std.stitches"))[0] == 0


# ---- images -------------------------------------------------------------------------------


def image_design(tree: Path, name: str) -> str:
    return design(tree, f'pattern a {{ set P where img("{name}") }}')


def png_header(width: int, height: int) -> bytes:
    """A PNG that declares `width` x `height` pixels and holds none (a bomb's header)."""

    def chunk(kind: bytes, body: bytes) -> bytes:
        return (
            struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
        )

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IEND", b"")


@pytest.mark.parametrize(
    ("name", "how"),
    [
        ("/etc/passwd", "an absolute path"),
        ("../outside/secret.txt", "`..` leads out"),
    ],
)
def test_images_outside_the_folders_are_refused(tree, capsys, name, how):
    code, err = check(capsys, image_design(tree, name))
    assert code == 1 and only_error(err)[0] == "E226" and how in err
    assert "reads images only below" in err


def test_an_image_symlinked_to_a_device_is_refused(tree, capsys):
    (tree / "proj" / "zero.png").symlink_to("/dev/zero")
    code, err = check(capsys, image_design(tree, "zero.png"))
    assert code == 1 and only_error(err)[0] == "E226"


@pytest.mark.parametrize("kind", ["fifo", "directory"])
def test_an_image_that_is_not_a_regular_file_is_not_read(tree, capsys, kind):
    target = tree / "proj" / "x.png"
    os.mkfifo(target) if kind == "fifo" else target.mkdir()
    code, err = check(capsys, image_design(tree, "x.png"))
    assert code == 1 and only_error(err)[0] == "E713"
    assert ("a directory" if kind == "directory" else "not a regular file") in err


def test_an_image_larger_than_the_limit_is_refused(tree, capsys, monkeypatch):
    from knitc.patterning import raster

    (tree / "proj" / "big.png").write_bytes(png_header(2, 2))
    monkeypatch.setattr(raster, "MAX_IMAGE_BYTES", 16)
    code, err = check(capsys, image_design(tree, "big.png"))
    assert code == 1 and only_error(err)[0] == "E713" and "knitc reads at most 16" in err


@pytest.mark.parametrize(("w", "h"), [(5000, 5000), (100_000, 100_000)])
def test_a_decompression_bomb_is_refused_from_its_header(tree, capsys, w, h):
    # 25 megapixels is over knitc's limit; 10 gigapixels is over Pillow's own too (its
    # DecompressionBombError): both are located errors, neither decodes a pixel
    (tree / "proj" / "bomb.png").write_bytes(png_header(w, h))
    code, err = check(capsys, image_design(tree, "bomb.png"))
    assert code == 1 and only_error(err)[0] == "E713" and "at most 16777216 pixels" in err


def test_only_plain_raster_formats_are_decoded(tree, capsys):
    # Pillow would hand an EPS to Ghostscript, an interpreter of PostScript programs
    (tree / "proj" / "x.png").write_bytes(b"%!PS-Adobe-3.0 EPSF-3.0\n%%BoundingBox: 0 0 1 1\n")
    code, err = check(capsys, image_design(tree, "x.png"))
    assert code == 1 and only_error(err)[0] == "E713" and "use PNG, JPEG, GIF or BMP" in err


# ---- the policy itself --------------------------------------------------------------------


def test_roots_are_judged_by_real_paths(tmp_path):
    (tmp_path / "a").mkdir()
    (tmp_path / "ab").mkdir()
    roots = access.ReadRoots.for_design(str(tmp_path / "a" / "d.knit"))
    assert roots.contains(os.path.realpath(tmp_path / "a" / "x.knit"))
    assert not roots.contains(os.path.realpath(tmp_path / "ab" / "x.knit"))  # not a prefix
    assert access.ReadRoots.for_design("<input>").shown == (".",)
    assert access.ReadRoots.for_design("d.knit", ["lib"]).describe() == "`.` and `lib`"


def test_no_construct_can_run_python_or_a_program():
    # docs/security.md promises this: the compiler has no eval, exec, pickle or subprocess
    # (knitc's own evaluators have methods named `eval`: `self.eval(...)`, `def eval`)
    builtin = r"(?<![\w.])(?<!def )(eval|exec|compile|__import__)\("
    banned = re.compile(builtin + r"|\bpickle\b|\bsubprocess\b|\bos\.(system|popen|exec)")
    root = Path(__file__).parent.parent / "compiler" / "knitc"
    found = [
        f"{p.relative_to(root)}:{n}"
        for p in sorted(root.rglob("*.py"))
        for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
        if banned.search(line)
    ]
    assert not found, found
