import io
import json
import re

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from doodle.animate import AnimateOptions, animate, animate_many, render_frames
from doodle.cameras import orbit_cameras
from doodle.cli import cli
from doodle.errors import DoodleError
from doodle.exporters import DrawOptions, draw, svg_to_png, to_svg
from doodle.strokes import write_strokes
from doodle.styles import builtin_names, load_style, style_from_dict
from doodle.exporters.style_preview import sample_strokes

REQUIRED = {"ink", "pen", "pencil", "charcoal", "marker", "sketchy", "blueprint"}


def _svg(style, strokes=None, view=1, size=256, **kw):
    s = strokes or sample_strokes()
    cam = orbit_cameras(s.frame, 8, size, size)[view]
    return to_svg(draw(s, cam, DrawOptions(tolerance=0.25, hidden=style.hidden_mode or "hide")), 0.25, style=style, **kw)


def _raster(svg):
    from doodle.exporters import svg_to_array

    return svg_to_array(svg, None)


class TestStyleData:
    def test_builtins_exist_and_validate(self):
        assert REQUIRED <= set(builtin_names())
        for name in builtin_names():
            st = load_style(name)
            assert st.name == name and st.description

    def test_builtins_are_written_in_the_user_format(self, tmp_path):
        import importlib.resources as r

        text = (r.files("doodle.styles") / "builtin" / "pencil.toml").read_text()
        (tmp_path / "mine.toml").write_text(text.replace('name = "pencil"', 'name = "mine"'))
        mine = load_style(tmp_path / "mine.toml")
        assert mine.line == load_style("pencil").line and mine.name == "mine"

    def test_json_style(self, tmp_path):
        p = tmp_path / "s.json"
        p.write_text(json.dumps({"line": {"color": "#ff0000", "passes": 2, "jitter": 1.0}}))
        st = load_style(p)
        assert st.name == "s" and st.line.passes == 2 and st.line.color == "#ff0000"

    @pytest.mark.parametrize("doc,field", [
        ({"line": {"width": -1}}, "line.width"), ({"line": {"color": "red"}}, "line.color"),
        ({"line": {"passes": 1.5}}, "line.passes"), ({"line": {"wobble": 1}}, "line.wobble"),
        ({"colour": "#fff"}, "colour"), ({"background": "blue-ish"}, "background"),
        ({"line": {"blend": "screen"}}, "line.blend"), ({"hidden": {"dash": [1, -2]}}, "hidden.dash"),
        ({"line": 3}, "line"),
    ])
    def test_errors_name_the_field(self, doc, field):
        with pytest.raises(DoodleError, match=re.escape(field)):
            style_from_dict(doc, "x.toml")

    def test_unknown_name_lists_builtins(self):
        with pytest.raises(DoodleError, match="built-in: blueprint, charcoal"):
            load_style("watercolour")

    def test_malformed_toml(self, tmp_path):
        p = tmp_path / "bad.toml"
        p.write_text("[line\ncolor = ")
        with pytest.raises(DoodleError, match="bad.toml: not valid TOML"):
            load_style(p)


class TestStyledSvg:
    def test_styles_look_different(self):
        rasters = {n: _raster(_svg(load_style(n))).astype(float) for n in sorted(REQUIRED)}
        names = sorted(rasters)
        for i, a in enumerate(names):
            for b in names[i + 1:]:
                assert np.abs(rasters[a] - rasters[b]).mean() > 0.5, (a, b)

    def test_plain_paths_in_named_layers_hex_colours(self):
        for name in REQUIRED:
            svg = _svg(load_style(name), filters=False)
            assert 'inkscape:label="curves"' in svg and 'inkscape:label="silhouettes"' in svg
            assert "<filter" not in svg and "url(#" not in svg
            colours = set(re.findall(r'(?:stroke|fill)="([^"]+)"', svg)) - {"none"}
            assert all(re.fullmatch(r"#[0-9a-fA-F]{6}", c) for c in colours), colours
            assert "<script" not in svg

    def test_filters_only_when_allowed(self):
        st = load_style("charcoal")
        assert "<filter" in _svg(st) and "<filter" not in _svg(st, filters=False)

    def test_pen_draws_filled_outlines(self):
        svg = _svg(load_style("pen"))
        tag = re.search(r'<g [^>]*id="layer-curves"[^>]*>', svg).group(0)
        assert 'fill="#' in tag and 'stroke="none"' in tag

    def test_blueprint_dashes_hidden_lines(self):
        st = load_style("blueprint")
        assert st.hidden_mode == "dash"
        assert 'inkscape:label="hidden"' in _svg(st) and "stroke-dasharray" in _svg(st)

    def test_deterministic_and_seeded_per_stroke(self):
        """A sketchy drawing is the same bytes in another process (nothing hangs on hash order or global
        state), and its wobble follows the style's seed."""
        from helpers import in_a_fresh_process

        st = load_style("sketchy")
        there = in_a_fresh_process("import sys, test_styles as t; from doodle.styles import load_style; "
                                   "sys.stdout.write(t._svg(load_style('sketchy')))")
        assert _svg(st).encode() == there
        other = style_from_dict({**{"line": {"passes": 2, "jitter": 2.4, "overshoot": 9.0}}, "seed": 7})
        assert _svg(other) != _svg(style_from_dict({"line": {"passes": 2, "jitter": 2.4, "overshoot": 9.0}}))

    def test_jitter_follows_the_stroke_not_the_frame(self):
        """The offset of a stroke from its exact centre line is the same function of arc length in every frame."""
        from doodle.styles.render import styled_path_data

        st = load_style("sketchy")
        s = sample_strokes()
        offsets = []
        for cam in orbit_cameras(s.frame, 12, 256, 256)[:2]:
            op = [p for p in draw(s, cam, DrawOptions(tolerance=0.25)).paths if p.id == "curve-000"][0]
            d = styled_path_data(op.subpaths, op.closed, st, op.id, 1.5, outline=False)[0]
            pts = np.array([[float(v) for v in m.split()] for m in re.findall(r"[ML]([-\d.]+ [-\d.]+)", d)])
            from doodle.styles.render import sample_polyline

            base = sample_polyline(op.subpaths[0])
            core = pts[1:-1][: len(base)]  # drop the overshoot points
            offsets.append(np.linalg.norm(core - base[: len(core)], axis=1))
        n = min(len(o) for o in offsets)
        assert np.corrcoef(offsets[0][:n], offsets[1][:n])[0, 1] > 0.9


class TestAnimation:
    def test_gif_frames_size_and_loop(self, tmp_path):
        out = animate(sample_strokes(), tmp_path / "t.gif", AnimateOptions(frames=6, size=96, fps=10))
        with Image.open(out) as im:
            assert im.n_frames == 6 and im.size == (96, 96) and im.info.get("loop") == 0
            assert im.info["duration"] == 100

    @staticmethod
    def _after_the_last_is_the_first(strokes, camera_at, n: int) -> bool:
        """Whether the frame after the last of ``n`` (camera ``camera_at(n)``) is the first again: the same pose
        and the same picture."""
        first, after = camera_at(0), camera_at(n)
        if not (np.allclose(first.R, after.R, atol=1e-9) and np.allclose(first.t, after.t, atol=1e-9)):
            return False
        picture = lambda cam: np.asarray(Image.open(io.BytesIO(svg_to_png(to_svg(draw(strokes, cam))))))  # noqa: E731
        return bool((picture(first) == picture(after)).all())

    def test_seamless_loop_with_bob(self):
        """The turntable's frames are the orbit's cameras 0 .. n-1, and camera n, the frame after the last, is
        frame 0 again (the camera and the drawing), bob included. A period off by a frame fails the check."""
        from doodle.cameras import orbit_camera

        s, n = sample_strokes(), 8
        svgs, frames = render_frames(s, AnimateOptions(frames=n, size=64, bob_deg=10))
        camera_at = lambda i, views=n: orbit_camera(s.frame, i, views, 64, 64, elevation_bob_deg=10)  # noqa: E731
        assert len(frames) == n
        for k in range(n):  # the frames are drawn from these cameras (each SVG records its camera)
            cam = json.loads(re.search(r'<metadata id="doodle-metadata">(.*?)</metadata>', svgs[k]).group(1))["camera"]
            assert np.allclose(cam["R"], camera_at(k).R, atol=1e-8) and np.allclose(cam["t"], camera_at(k).t, atol=1e-8)
        assert self._after_the_last_is_the_first(s, camera_at, n)
        assert not self._after_the_last_is_the_first(s, lambda i: camera_at(i, n + 1), n)  # a frame too many
        assert not self._after_the_last_is_the_first(s, lambda i: camera_at(i, n - 1), n)  # one too few

    def test_same_stroke_same_jitter_across_frames_no_flicker(self):
        """Two renders of the same frame are identical, and consecutive frames differ only a little."""
        s = sample_strokes()
        opt = AnimateOptions(frames=72, size=128, style="pencil")
        _, a = render_frames(s, opt)
        _, b = render_frames(s, opt)
        arr = [np.asarray(x, float) for x in a]
        assert all((np.asarray(x) == np.asarray(y)).all() for x, y in zip(a, b))
        steps = [np.abs(arr[k + 1] - arr[k]).mean() for k in range(len(arr) - 1)]
        assert max(steps) < 4 * np.median(steps) + 0.5

    def test_apng_and_animated_svg(self, tmp_path):
        written = animate_many(sample_strokes(), {"apng": tmp_path / "t.png", "svg": tmp_path / "t.svg"},
                               AnimateOptions(frames=4, size=64))
        with Image.open(written[0]) as im:
            assert im.n_frames == 4
        svg = (tmp_path / "t.svg").read_text()
        assert svg.count('<g id="frame-') == 4 and 'repeatCount="indefinite"' in svg and "<script" not in svg
        ids = re.findall(r'id="([^"]+)"', svg)
        assert len(ids) == len(set(ids))

    def test_mp4(self, tmp_path):
        pytest.importorskip("imageio_ffmpeg", reason="optional extra doodle3d[video] not installed")
        import imageio.v2 as iio

        out = animate(sample_strokes(), tmp_path / "t.mp4", AnimateOptions(frames=6, size=64, workers=1))
        reader = iio.get_reader(out)
        assert reader.count_frames() == 6 and reader.get_meta_data()["size"] == (64, 64)

    def test_mp4_without_ffmpeg_is_a_clear_error(self, tmp_path, monkeypatch):
        import builtins

        real = builtins.__import__

        def fake(name, *a, **k):
            if name == "imageio_ffmpeg":
                raise ImportError(name)
            return real(name, *a, **k)

        monkeypatch.setattr(builtins, "__import__", fake)
        with pytest.raises(DoodleError, match="imageio-ffmpeg"):
            animate(sample_strokes(), tmp_path / "t.mp4", AnimateOptions(frames=2, size=32))
        assert not (tmp_path / "t.mp4").exists()

    def test_bad_frames(self, tmp_path):
        with pytest.raises(DoodleError, match="--frames"):
            animate(sample_strokes(), tmp_path / "t.gif", AnimateOptions(frames=0))
        assert not (tmp_path / "t.gif").exists()


class TestCli:
    @pytest.fixture
    def strokes_file(self, tmp_path):
        p = tmp_path / "s.doodle"
        write_strokes(p, sample_strokes())
        return p

    def test_styles_list_and_preview(self, tmp_path):
        r = CliRunner().invoke(cli, ["styles", "--preview", str(tmp_path / "p.png")])
        assert r.exit_code == 0 and all(n in r.output for n in REQUIRED)
        assert Image.open(tmp_path / "p.png").size[0] >= 4 * 256

    def test_export_with_style(self, strokes_file, tmp_path):
        r = CliRunner().invoke(cli, ["export", str(strokes_file), "-o", str(tmp_path / "o"), "--views", "2",
                                     "--style", "blueprint", "--size", "96"])
        assert r.exit_code == 0, r.output
        assert "#1d4f91" in (tmp_path / "o" / "view_000.svg").read_text()

    def test_animate_gif(self, strokes_file, tmp_path):
        r = CliRunner().invoke(cli, ["animate", str(strokes_file), "--gif", str(tmp_path / "a.gif"), "--frames", "4",
                                     "--size", "64", "--style", "marker", "--bob", "5"])
        assert r.exit_code == 0, r.output
        assert Image.open(tmp_path / "a.gif").n_frames == 4

    @pytest.mark.parametrize("args,msg", [(["--style", "nope"], "unknown style"), (["--frames", "0"], "--frames"),
                                          ([], "choose at least one")])
    def test_animate_bad_input(self, strokes_file, tmp_path, args, msg):
        out = tmp_path / "a.gif"
        extra = [] if args == [] else ["--gif", str(out)]
        r = CliRunner().invoke(cli, ["animate", str(strokes_file), *extra, *args])
        assert r.exit_code == 2 and msg in r.output and r.output.strip().count("\n") == 0
        assert not out.exists()

    @pytest.mark.parametrize("command", ["animate", "export", "view", "fit"])
    def test_an_output_that_cannot_be_written_is_one_line_and_writes_nothing(self, strokes_file, tmp_path, command):
        """An output under a file instead of a folder fails for every user, root included (who ignores a
        folder's permissions): one line naming the path, exit 2, before any work."""
        blocker = tmp_path / "not-a-folder"
        blocker.write_text("a file")
        out = blocker / "out"
        argv = {"animate": ["animate", str(strokes_file), "--gif", f"{out}.gif", "--frames", "2"],
                "export": ["export", str(strokes_file), "-o", str(out), "--views", "2"],
                "view": ["view", str(strokes_file), "-o", f"{out}.html", "--azimuths", "2", "--elevations", "0"],
                "fit": ["fit", str(tmp_path / "no-scene"), "-o", f"{out}.doodle"]}[command]
        r = CliRunner().invoke(cli, argv)
        assert r.exit_code == 2 and r.output.startswith("Error: ") and r.output.strip().count("\n") == 0, r.output
        assert f"{blocker} is a file, not a folder" in r.output
        assert blocker.read_text() == "a file" and {p.name for p in tmp_path.iterdir()} == {"not-a-folder", "s.doodle"}

    def test_malformed_style_file(self, strokes_file, tmp_path):
        bad = tmp_path / "b.toml"
        bad.write_text('[line]\nwidth = "thick"\n')
        r = CliRunner().invoke(cli, ["animate", str(strokes_file), "--gif", str(tmp_path / "a.gif"), "--style", str(bad)])
        assert r.exit_code == 2 and "line.width" in r.output
