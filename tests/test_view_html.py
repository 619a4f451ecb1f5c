"""The interactive viewer (`knitc view FILE --html`): the page and its data, then the page in
a real browser.

Without a browser: every shipped design renders into one self-contained page (no address
to fetch, no external script or style), whose embedded data is the design's (every stitch,
every op, a row per carriage pass, the text of the source lines) and whose bytes are the
same on every run. The chart geometry is checked here too, since hovering relies on it: no
two stitches share a chart cell.

In a browser: headless Chromium (Debian's `chromium` and `chromium-driver`, which
`.ci/install-browser` installs) driven by selenium loads the file, the test hovers a stitch
and an op at the pixel the page says it drew them, reads the tooltip, clicks a warning, and
inspects screenshots with Pillow. Without the browser these tests skip, saying how to get it;
under CI (the `CI` variable set, as `.ci/run` runs) they fail instead, so CI cannot pass
without running them.
"""

from __future__ import annotations

import io
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

from ci_tools import need
from knitc.codegen.machine import estimate_passes
from knitc.shaping.stitch_graph import INSTRUCTIONS
from knitc.source import SourceFile
from knitc.view import html as view_html
from knitc.view import render_file
from knitc.view.source import load

REPO = Path(__file__).resolve().parents[1]
DESIGNS = sorted(
    p.relative_to(REPO).as_posix()
    for p in [*REPO.glob("examples/*.knit"), *REPO.glob("examples/knitskel/*.knit")]
)
DATA_RE = re.compile(r'<script type="application/json" id="knitc-data">(.*?)</script>', re.DOTALL)


@pytest.fixture(autouse=True)
def _in_repo(monkeypatch):
    """Paths in the page are as given, so run from the repository like a user would."""
    monkeypatch.chdir(REPO)


def page_data(text: str) -> dict:
    (raw,) = DATA_RE.findall(text)
    return json.loads(raw)


@pytest.fixture(scope="module")
def pages() -> dict[str, tuple[object, str]]:
    """Each design's view input and page, rendered once for the whole module."""
    old = os.getcwd()
    os.chdir(REPO)
    try:
        out = {}
        for path in DESIGNS:
            got = load(path)
            assert got.input is not None, got.diagnostics.render()
            out[path] = (got.input, view_html.render(got.input).decode("utf-8"))
        return out
    finally:
        os.chdir(old)


# ---- the page, without a browser ----------------------------------------------------------


@pytest.mark.parametrize("path", DESIGNS)
def test_page_is_self_contained(pages, path):
    _, text = pages[path]
    assert "http://" not in text and "https://" not in text
    assert not re.search(r"<script[^>]*\ssrc\s*=", text, re.IGNORECASE)
    for tag in re.findall(r"<link\b[^>]*>", text, re.IGNORECASE):
        assert 'href="data:' in tag, f"a link that is not inline: {tag}"
    for attr in re.findall(r"\b(?:src|href)\s*=\s*\"([^\"]*)\"", text, re.IGNORECASE):
        assert attr.startswith("data:"), attr
    assert "default-src 'none'" in text  # the browser is told to fetch nothing either
    assert "@import" not in text and "url(" not in text


@pytest.mark.parametrize("path", DESIGNS)
def test_page_holds_the_design(pages, path):
    inp, text = pages[path]
    data = page_data(text)
    g, prog = inp.graph, inp.program
    assert data["file"] == path and data["design"] is True
    ops = data["ops"]
    assert ops["count"] == len(prog.ops)
    assert all(len(ops[k]) == len(prog.ops) for k in ("kind", "needle", "span", "pass"))
    assert ops["passes"] == estimate_passes(prog.ops)  # one bed row per pass knitc counts
    st = data["stitches"]
    assert st["count"] == g.n_stitches
    for k in ("node", "course", "wale", "instr", "span", "op", "chart_x", "shape_x"):
        assert len(st[k]) == g.n_stitches, k
    assert st["nodes"] == list(g.node_names)
    assert [INSTRUCTIONS[i] for i in st["instr"]] == [INSTRUCTIONS[i] for i in g.instr]
    # every stitch's op is one the stitch made, and knitc's findings are all listed
    made = np.array([op.stitch for op in prog.ops])
    has = np.array(st["op"]) >= 0
    assert np.all(made[np.array(st["op"])[has]] == np.nonzero(has)[0])
    assert has.mean() > 0.95
    assert len([w for w in data["warnings"] if w["source"] == "simulation"]) == len(inp.findings)
    assert len(data["warnings"]) >= len(inp.findings)


@pytest.mark.parametrize("path", DESIGNS)
def test_source_lines_are_the_files(pages, path):
    _, text = pages[path]
    data = page_data(text)
    sources = {}
    for f, line, _col, _parent in data["spans"]:
        name = data["files"][f]
        if name not in sources:
            if name.startswith("<stdlib>/"):
                from knitc.resources import stdlib_root

                body = stdlib_root().joinpath(name.removeprefix("<stdlib>/")).read_text("utf-8")
            else:
                body = Path(name).read_text(encoding="utf-8")
            sources[name] = SourceFile(name, body)
        assert data["lines"][f"{f}:{line}"] == sources[name].line_text(line)


@pytest.mark.parametrize("path", DESIGNS)
def test_chart_cells_are_distinct(pages, path):
    """Hovering finds one stitch per cell: no two stitches are drawn in the same place, and
    a tube's front face is left of its back face."""
    inp, text = pages[path]
    st = page_data(text)["stitches"]
    cells = set(zip(st["chart_x"], st["chart_y"]))
    assert len(cells) == st["count"]
    g = inp.graph
    x = np.array(st["chart_x"])
    for c in np.nonzero(g.course_circular)[0][:50]:
        ids = g.course_ids(int(c))
        front, back = ids[g.side[ids] == 0], ids[g.side[ids] == 1]
        if front.size and back.size:
            assert x[front].max() < x[back].min()


def test_warnings_point_at_their_stitches(pages):
    inp, text = pages["examples/tube.knit"]
    data = page_data(text)
    (w,) = [w for w in data["warnings"] if w["code"] == "W708"]
    assert w["stitches"], "the warning's line wrote stitches; the panel must show them"
    line = data["spans"][w["span"]][1]
    g = inp.graph
    tops = {i for i, s in enumerate(g.spans) if s.chain()[0].line == line}
    assert all(int(g.origin[s]) in tops or int(g.span[s]) in tops for s in w["stitches"])


def test_sweater_finding_is_at_its_op(pages):
    inp, text = pages["examples/sweater.knit"]
    data = page_data(text)
    (f,) = inp.findings
    (w,) = [w for w in data["warnings"] if w["source"] == "simulation"]
    assert w["code"] == f.code and w["ops"] == [f.op] and w["op_text"] == str(inp.program.ops[f.op])
    # the compilation reports the same hazard; the panel lists it once
    assert [x["code"] for x in data["warnings"]].count(f.code) == 1


def test_knitout_input_has_the_bed_only(tmp_path):
    k = tmp_path / "sheet.k"
    from knitc.cli import main

    assert main(["examples/sheet.knit", "-o", str(k), "--quiet"]) == 0
    diags, data = render_file(str(k), "html", ".html")
    assert data is not None and not diags.has_errors
    d = page_data(data.decode("utf-8"))
    assert d["design"] is False and "stitches" not in d
    assert d["ops"]["passes"] > 0
    assert d["lines"]["0:8"] == k.read_text().splitlines()[7]


def test_page_is_deterministic(tmp_path):
    """Byte-identical pages from two processes with different hash seeds (so no set or dict
    order of str hashes leaks into the page)."""
    outs = []
    for seed in ("1", "2"):
        out = tmp_path / f"v{seed}.html"
        subprocess.run(
            [
                sys.executable,
                "-m",
                "knitc",
                "view",
                "examples/tube.knit",
                "--html",
                "-o",
                str(out),
                "-q",
            ],
            check=True,
            cwd=REPO,
            env={**os.environ, "PYTHONHASHSEED": seed},
        )
        outs.append(out.read_bytes())
    assert outs[0] == outs[1]
    assert outs[0].startswith(b"<!DOCTYPE html>")


def test_json_cannot_end_the_script():
    text = view_html._json_for_script({"a": "</script><!-- http://x & y"})
    assert "</" not in text and "<!--" not in text and "://" not in text
    assert json.loads(text) == {"a": "</script><!-- http://x & y"}


def test_shape_falls_back_without_a_layout(pages, monkeypatch):
    import knitc.view.shape as shape_mod

    inp, _ = pages["examples/sock.knit"]
    monkeypatch.delattr(shape_mod, "layout")
    pts, how = view_html.shape_layout(inp.graph)
    assert how == "courses" and pts.shape == (inp.graph.n_stitches, 2)


# ---- the page in a browser ------------------------------------------------------------------

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
CHROMEDRIVER = shutil.which("chromedriver") or "/usr/bin/chromedriver"
WIDTH, HEIGHT = 1280, 860


def _need(ok: bool, reason: str) -> None:
    __tracebackhide__ = True
    need(ok, reason, "the browser test")


@pytest.fixture(scope="module")
def driver():
    have = os.access(CHROMIUM, os.X_OK) and os.access(CHROMEDRIVER, os.X_OK)
    _need(
        have,
        f"headless Chromium is not installed ({CHROMIUM}, {CHROMEDRIVER}): "
        "run `.ci/install-browser` (Debian's chromium and chromium-driver)",
    )
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        _need(False, "selenium is not installed: `pip install .[test]` (make test does it)")
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    profile = tempfile.mkdtemp(prefix="knitc-chromium-")
    for arg in (
        "--headless=new",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-dev-shm-usage",
        # this machine has no network: keep Chromium from trying, it only logs noise
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--disable-quic",
        "--no-first-run",
        "--force-device-scale-factor=1",
        f"--window-size={WIDTH},{HEIGHT}",
        f"--user-data-dir={profile}",
    ):
        opts.add_argument(arg)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    d = webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)
    try:
        yield d
    finally:
        d.quit()
        shutil.rmtree(profile, ignore_errors=True)


@pytest.fixture(scope="module")
def tube_page(tmp_path_factory):
    """The viewer of examples/tube.knit (a shaped tube, a tuck band, one warning)."""
    old = os.getcwd()
    os.chdir(REPO)
    try:
        got = load("examples/tube.knit")
        assert got.input is not None
        out = tmp_path_factory.mktemp("view") / "tube.html"
        out.write_bytes(view_html.render(got.input))
        return got.input, out
    finally:
        os.chdir(old)


def _open(d, path: Path) -> None:
    d.get(path.resolve().as_uri())
    deadline = time.monotonic() + 20
    while not d.execute_script("return !!(window.knitcViewer && window.knitcViewer.ready)"):
        assert time.monotonic() < deadline, "the viewer did not start"
        time.sleep(0.05)
    d.get_log("browser")  # start each test's log afresh


def _severe(d) -> list[dict]:
    return [e for e in d.get_log("browser") if e.get("level") == "SEVERE"]


def _hover(d, what: str, ident: int, px: int = 20) -> str:
    """Move the mouse onto item `ident` where the page says it drew it; the tooltip's text."""
    from selenium.common.exceptions import TimeoutException
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.support.ui import WebDriverWait

    at = d.execute_script(f"return window.knitcViewer.focus('{what}', {ident}, {px});")
    assert at is not None, f"{what} {ident} is not in the view"
    canvas = d.find_element("id", "canvas")
    size = canvas.size
    dx = round(at["x"] - size["width"] / 2)
    dy = round(at["y"] - size["height"] / 2)
    # From a corner first: a move to where the mouse already is fires no mousemove.
    corner = (2 - size["width"] // 2, 2 - size["height"] // 2)
    ActionChains(d).move_to_element_with_offset(canvas, *corner).perform()
    ActionChains(d).move_to_element_with_offset(canvas, dx, dy).perform()
    tip = d.find_element("id", "tooltip")
    head = f"{what} {ident}:"
    try:
        WebDriverWait(d, 5).until(lambda _: tip.is_displayed() and tip.text.startswith(head))
    except TimeoutException:
        raise AssertionError(f"no tooltip for {head} at {at}; it shows {tip.text!r}") from None
    return tip.text


def _click_tab(d, view: str) -> None:
    d.find_element("css selector", f'#tabs button[data-view="{view}"]').click()
    assert d.execute_script("return window.knitcViewer.view();") == view


def _screenshot(d):
    from PIL import Image

    return Image.open(io.BytesIO(d.get_screenshot_as_png())).convert("RGB")


def _count(img, hex_colour: str, tol: int = 8) -> int:
    a = np.asarray(img).astype(np.int16)
    rgb = np.array([int(hex_colour[i : i + 2], 16) for i in (1, 3, 5)], np.int16)
    return int(np.all(np.abs(a - rgb) <= tol, axis=2).sum())


def test_browser_renders_every_view_without_errors(driver, tube_page):
    _, path = tube_page
    _open(driver, path)
    for view in ("bed", "chart", "shape"):
        _click_tab(driver, view)
    driver.find_element("id", "fit").click()
    assert _severe(driver) == []
    assert "examples/tube.knit" in driver.find_element("id", "title").text
    assert driver.find_element("id", "warnings").text.count("W708") == 1


def test_hovering_a_stitch_shows_its_source_line(driver, tube_page):
    inp, path = tube_page
    _open(driver, path)
    _click_tab(driver, "chart")
    g = inp.graph
    tucks = np.nonzero(g.instr == INSTRUCTIONS.index("T"))[0]
    for s in (int(tucks[len(tucks) // 2]), g.n_stitches // 3):
        text = _hover(driver, "stitch", s)
        span = g.spans[int(g.span[s])]
        line = inp.diagnostics.sources[span.file].line_text(span.line).strip()
        assert f"stitch {s}: node {g.node_names[int(g.node[s])]}" in text
        assert f"{span.file}:{span.line}:{span.column}" in text
        assert line in text
        assert f"instruction {INSTRUCTIONS[int(g.instr[s])]}" in text
        assert re.search(r"needle [fb]\d+", text)
    # the tuck's tooltip also names the pattern line that made it a tuck
    text = _hover(driver, "stitch", int(tucks[0]))
    assert "pattern examples/tube.knit:36:3" in text and "apply tuck_stitch()" in text
    assert _severe(driver) == []


def test_hovering_an_op_shows_its_source_line(driver, tube_page):
    inp, path = tube_page
    _open(driver, path)
    _click_tab(driver, "bed")
    ops = inp.program.ops
    i = next(k for k, op in enumerate(ops) if op.kind == "xfer" and op.span is not None)
    text = _hover(driver, "op", i)
    span = ops[i].span
    assert f"op {i}: {ops[i]}" in text
    assert f"{span.file}:{span.line}:{span.column}" in text
    assert inp.diagnostics.sources[span.file].line_text(span.line).strip() in text
    assert _severe(driver) == []


def test_wheel_zooms_and_drag_pans(driver, tube_page):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.actions.wheel_input import ScrollOrigin

    inp, path = tube_page
    _open(driver, path)
    _click_tab(driver, "chart")
    s = inp.graph.n_stitches // 2
    at = driver.execute_script(f"return window.knitcViewer.focus('stitch', {s}, 10);")
    canvas = driver.find_element("id", "canvas")
    # zoom in around the stitch: it gets bigger and stays under the mouse
    dx, dy = round(at["x"] - canvas.size["width"] / 2), round(at["y"] - canvas.size["height"] / 2)
    origin = ScrollOrigin.from_element(canvas, dx, dy)
    ActionChains(driver).scroll_from_origin(origin, 0, -400).perform()
    time.sleep(0.2)
    zoomed = driver.execute_script(f"return window.knitcViewer.itemPixel('stitch', {s});")
    assert zoomed["cell"] > at["cell"] * 1.5
    assert abs(zoomed["x"] - at["x"]) < 3 and abs(zoomed["y"] - at["y"]) < 3
    # drag: the picture follows the mouse
    chain = ActionChains(driver).move_to_element_with_offset(canvas, dx, dy).click_and_hold()
    chain.move_by_offset(60, -40).release().perform()
    time.sleep(0.2)
    moved = driver.execute_script(f"return window.knitcViewer.itemPixel('stitch', {s});")
    assert abs(moved["x"] - zoomed["x"] - 60) < 3 and abs(moved["y"] - zoomed["y"] + 40) < 3
    assert _severe(driver) == []


def test_clicking_a_warning_highlights_its_stitches(driver, tube_page):
    _, path = tube_page
    _open(driver, path)
    _click_tab(driver, "chart")
    driver.find_element("css selector", "#warnings li").click()
    n = driver.execute_script("return window.knitcViewer.highlighted();")
    data = driver.execute_script("return window.knitcViewer.data.warnings[0].stitches.length;")
    assert n == data > 0
    img = _screenshot(driver)
    assert _count(img, "#ff00ff") > 100  # the highlight is drawn
    assert "selected" in driver.find_element("css selector", "#warnings li").get_attribute("class")
    assert _severe(driver) == []


def test_screenshots_show_the_views(driver, tube_page, tmp_path):
    _, path = tube_page
    _open(driver, path)
    colours = driver.execute_script("return window.knitcViewer.colours;")
    _click_tab(driver, "chart")
    driver.find_element("id", "fit").click()
    img = _screenshot(driver)
    img.save(tmp_path / "chart.png")
    assert img.size[0] >= WIDTH * 0.9
    assert len(np.unique(np.asarray(img).reshape(-1, 3), axis=0)) > 20, "a blank screenshot"
    assert _count(img, colours["instructions"]["K"]) > 20000  # plain stitches
    assert _count(img, colours["instructions"]["T"]) > 200  # the tuck band
    _click_tab(driver, "bed")
    img = _screenshot(driver)
    img.save(tmp_path / "bed.png")
    for kind in ("knit", "tuck"):
        assert _count(img, colours["kinds"][kind]) > 500, kind
    _click_tab(driver, "shape")
    img = _screenshot(driver)
    assert _count(img, "#4c78a8") > 5000  # the sleeve, in its node colour
    assert _severe(driver) == []


def test_knitout_page_says_the_other_views_need_a_design(driver, tmp_path):
    from knitc.cli import main

    k = tmp_path / "sheet.k"
    assert main(["examples/sheet.knit", "-o", str(k), "--quiet"]) == 0
    page = tmp_path / "sheet.html"
    assert main(["view", str(k), "--html", "-o", str(page), "--quiet"]) == 0
    _open(driver, page)
    assert driver.execute_script("return window.knitcViewer.view();") == "bed"
    prog = load(str(k)).input.program
    i = next(j for j, op in enumerate(prog.ops) if op.kind == "knit")
    text = _hover(driver, "op", i)
    # a Knitout op's source line is its line in the file
    line = prog.ops[i].span.line
    assert f"{k}:{line}:1" in text and k.read_text().splitlines()[line - 1] in text
    _click_tab(driver, "chart")
    notice = driver.find_element("id", "notice")
    assert notice.is_displayed() and "needs a design" in notice.text
    assert _severe(driver) == []
