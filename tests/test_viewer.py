"""The offline HTML viewer: its packed views are the exporter's drawings, and in a real headless Chromium it
opens from disk without network or console errors, turns when dragged, and saves the exporter's SVG.

The browser tests need Playwright (``pip install playwright``, no browser download) and a Chromium on the
PATH (Debian's ``chromium``); they skip cleanly without them."""

from __future__ import annotations

import base64
import gzip
import io
import json
import re
import shutil
import struct
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from doodle.cli import cli
from doodle.exporters import DrawOptions, draw, to_svg
from doodle.exporters.drawing import LAYERS
from doodle.exporters.viewer import ViewerOptions, leb128, pack_views, viewer_cameras, viewer_html
from doodle.strokes import write_strokes

from helpers import random_strokes

SMALL = ViewerOptions(azimuths=12, elevations=(0.0, 30.0), size=256, workers=1)


@pytest.fixture(scope="module")
def strokes():
    return random_strokes(5, n_curves=14, n_sq=3, extras=True)


@pytest.fixture(scope="module")
def page(strokes, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("viewer") / "sketch.html"
    out.write_text(viewer_html(strokes, SMALL, source="sketch.doodle"), encoding="utf-8")
    return out


def unpack_page(html: str) -> tuple[dict, list[list[tuple[int, str, str]]]]:
    """The page's data, decoded in Python the way the page's script decodes it."""
    b64 = re.search(r'<script id="doodle-data" type="application/octet-stream">([^<]*)</script>', html).group(1)
    raw = gzip.decompress(base64.b64decode(b64))
    (size,) = struct.unpack("<I", raw[:4])
    header = json.loads(raw[4:4 + size])
    pos = 4 + size

    def nxt() -> int:
        nonlocal pos
        value = shift = 0
        while True:
            byte = raw[pos]
            pos += 1
            value |= (byte & 0x7F) << shift
            shift += 7
            if not byte & 0x80:
                return value

    def signed() -> int:
        z = nxt()
        return -(z + 1) // 2 if z % 2 else z // 2

    def fmt(v: int) -> str:
        s = f"{v / 10 ** header['digits']:.{header['digits']}f}".rstrip("0").rstrip(".")
        return "0" if s in ("-0", "") else s

    views = []
    for _ in range(header["views"]):
        paths = []
        for _ in range(nxt()):
            layer, pid, d = nxt(), header["ids"][nxt()], ""
            for _ in range(nxt()):
                closed, pieces = nxt(), nxt()
                x = y = 0
                nums = []
                for _ in range(1 + 3 * pieces):
                    x += signed()
                    y += signed()
                    nums += [fmt(x), fmt(y)]
                d += f"M{nums[0]} {nums[1]}C" + " ".join(nums[2:]) + ("Z" if closed else "")
            paths.append((layer, pid, d))
        views.append(paths)
    assert pos == len(raw)
    return header, views


def exporter_paths(strokes, camera, tolerance: float, hidden: str = "hide") -> dict[str, str]:
    """``id → d`` of the exporter's own SVG for ``camera`` (plain ink style)."""
    svg = to_svg(draw(strokes, camera, DrawOptions(tolerance=tolerance, hidden=hidden)), tolerance)
    return {pid: d for d, pid in re.findall(r'<path d="([^"]*)" id="([^"]*)"', svg)}


def test_leb128_known_values():
    assert leb128(np.array([0, 1, 127, 128, 300, 2 ** 20])).hex() == "00017f8001ac02808040"


def test_pack_views_round_trips_path_text_exactly():
    views = [[(0, "silhouette-000-0", "M1.5 -2C3 4.25 -0.01 6 7 8Z"), (1, "curve-003", "M0 0C1 1 2 2 3 3M4 4C5 5 6 6 7 7")],
             [], [(2, "hidden-curve-003", "M-100.75 12C-99 13 98.5 0 1 -1")]]
    ids, stream = pack_views(views, 2)
    header = json.dumps({"digits": 2, "ids": ids, "views": len(views)}).encode()
    blob = base64.b64encode(gzip.compress(struct.pack("<I", len(header)) + header + stream)).decode()
    _, back = unpack_page(f'<script id="doodle-data" type="application/octet-stream">{blob}</script>')
    assert back == views


def test_every_view_is_the_exporters_drawing(strokes, page):
    """Each packed view, hidden layer left out, has the very path data ``doodle export`` writes for its camera."""
    header, views = unpack_page(page.read_text())
    cams = viewer_cameras(strokes, SMALL)
    assert header["views"] == len(cams) == 24 and len(header["cameras"]) == 24
    for k in (0, 5, 13, 23):
        mine = {pid: d for layer, pid, d in views[k] if LAYERS[layer] != "hidden"}
        assert mine == exporter_paths(strokes, cams[k], SMALL.tolerance)
        hidden = {pid: d for layer, pid, d in views[k] if LAYERS[layer] == "hidden"}
        theirs = exporter_paths(strokes, cams[k], SMALL.tolerance, "dash")
        assert hidden == {pid: d for pid, d in theirs.items() if pid.startswith("hidden-")}
        assert header["cameras"][k]["R"] == np.round(cams[k].R, 9).tolist()
    assert any(LAYERS[layer] == "hidden" for v in views for layer, _, _ in v)  # the dash/show choice has data


def test_page_is_self_contained(page):
    html = page.read_text()
    outside = re.findall(r'(?:src|href)\s*=\s*"(?!data:|#)[^"]*"', html) + re.findall(r"url\((?!#)[^)]*\)", html)
    assert outside == []
    assert "fetch(" not in html and "import(" not in html and "XMLHttpRequest" not in html
    assert "<!--DOODLE-" not in html and "/*DOODLE-DATA*/" not in html


def test_cli_view_writes_atomically_and_refuses_bad_input(tmp_path, strokes):
    src = tmp_path / "s.doodle"
    write_strokes(src, strokes)
    out = tmp_path / "s.html"
    r = CliRunner().invoke(cli, ["view", str(src), "--azimuths", "8", "--elevations", "0,40", "--size", "128"])
    assert r.exit_code == 0, r.output
    assert out.stat().st_size > 1000 and "16 views" in r.output
    before = out.read_bytes()
    for args, needle in ((["--elevations", "0,95"], "elevations"), (["--elevations", "a,b"], "--elevations"),
                         (["--azimuths", "0"], "--azimuths"), (["--style", "nope"], "nope")):
        r = CliRunner().invoke(cli, ["view", str(src), "-o", str(out), *args])
        assert r.exit_code == 2 and len(r.output.strip().splitlines()) == 1 and needle in r.output, r.output
        assert out.read_bytes() == before
    (tmp_path / "bad.doodle").write_text("{not json")
    r = CliRunner().invoke(cli, ["view", str(tmp_path / "bad.doodle"), "-o", str(out)])
    assert r.exit_code == 2 and "bad.doodle" in r.output and len(r.output.strip().splitlines()) == 1
    r = CliRunner().invoke(cli, ["view", str(src), "-o", str(tmp_path / "no" / "x.html")])
    assert r.exit_code == 2 and "does not exist" in r.output
    assert out.read_bytes() == before


# ---- in a real browser ------------------------------------------------------------------------------------

def _chromium() -> str | None:
    return next((p for p in map(shutil.which, ("chromium", "chromium-browser", "google-chrome")) if p), None)


@pytest.fixture(scope="module")
def browser():
    sync_api = pytest.importorskip("playwright.sync_api", reason="needs playwright (pip install playwright)")
    exe = _chromium()
    if exe is None:
        pytest.skip("needs a Chromium on the PATH (apt install chromium)")
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        yield b
        b.close()


def _open(browser, page_file: Path):
    tab = browser.new_page(viewport={"width": 800, "height": 760}, accept_downloads=True)
    problems: list[str] = []
    tab.on("console", lambda m: problems.append(f"console {m.type}: {m.text}") if m.type in ("error", "warning") else None)
    tab.on("pageerror", lambda e: problems.append(f"page error: {e}"))
    tab.on("request", lambda r: problems.append(f"request {r.url}") if not r.url.startswith(("file:", "data:", "blob:")) else None)
    tab.goto(page_file.as_uri())
    tab.wait_for_selector('body[data-ready="1"]', timeout=30_000)
    return tab, problems


def _ink(png: bytes, size: int) -> np.ndarray:
    from PIL import Image

    img = np.asarray(Image.open(io.BytesIO(png)).convert("L").resize((size, size), Image.BILINEAR), float)
    return img < 200


def test_browser_drag_turns_the_sketch_and_saves_the_exporters_svg(browser, page, strokes, tmp_path):
    tab, problems = _open(browser, page)
    cams = viewer_cameras(strokes, SMALL)
    first = int(tab.evaluate("document.body.dataset.view"))
    before = tab.locator("#sheet svg").inner_html()
    box = tab.locator("#stage").bounding_box()
    x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
    tab.mouse.move(x, y)
    tab.mouse.down()
    tab.mouse.move(x + 90, y + 40, steps=6)
    tab.mouse.up()
    k = int(tab.evaluate("document.body.dataset.view"))
    assert k != first and tab.locator("#sheet svg").inner_html() != before
    # what the page shows and saves is the exporter's SVG of that camera, path for path
    with tab.expect_download() as download:
        tab.click("#save")
    saved = Path(download.value.path()).read_text(encoding="utf-8")
    assert saved == tab.evaluate("window.doodle.svgText()")
    mine = {pid: d for d, pid in re.findall(r'<path d="([^"]*)" id="([^"]*)"', saved)}
    assert mine == exporter_paths(strokes, cams[k], SMALL.tolerance)
    meta = json.loads(re.search(r'<metadata id="doodle-metadata">([^<]*)</metadata>', saved).group(1).replace("&quot;", '"'))
    assert meta["camera"]["R"] == np.round(cams[k].R, 9).tolist()
    # and it looks like it: the screenshot's ink against cairosvg's drawing of the exporter's SVG
    from doodle.exporters import svg_to_png

    shot = _ink(tab.locator("#sheet").screenshot(), SMALL.size)
    ref = _ink(svg_to_png(to_svg(draw(strokes, cams[k], DrawOptions(tolerance=SMALL.tolerance)), SMALL.tolerance)),
               SMALL.size)
    from scipy.ndimage import distance_transform_edt

    near_ref = distance_transform_edt(~ref)[shot] <= 2
    near_shot = distance_transform_edt(~shot)[ref] <= 2
    assert ref.sum() > 200 and near_ref.mean() > 0.95 and near_shot.mean() > 0.95
    assert problems == []
    tab.close()


def test_browser_styles_hidden_lines_and_zoom(browser, page):
    tab, problems = _open(browser, page)
    svg = tab.locator("#sheet svg")
    assert svg.locator("#layer-hidden").count() == 0
    tab.select_option("#hidden", "dash")
    assert svg.locator("#layer-hidden").get_attribute("stroke-dasharray")
    tab.select_option("#hidden", "show")
    assert svg.locator("#layer-hidden").get_attribute("stroke-dasharray") is None
    tab.select_option("#style", "sketchy")  # two jittered passes a path
    assert svg.locator("path[id$='-pass1']").count() > 0
    d_sketchy = svg.locator("#layer-curves path").first.get_attribute("d")
    assert "C" not in d_sketchy and "L" in d_sketchy
    tab.select_option("#style", "pencil")  # grain filter and its background
    assert svg.locator("filter#doodle-grain").count() == 1
    box = tab.locator("#stage").bounding_box()
    tab.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    tab.mouse.wheel(0, -500)
    tab.wait_for_function("document.querySelector('#sheet svg').getAttribute('viewBox') !== '0 0 256 256'")
    w = float(svg.get_attribute("viewBox").split()[2])
    assert w < 256
    tab.dblclick("#stage")
    assert svg.get_attribute("viewBox") == "0 0 256 256"
    assert problems == []
    tab.close()
