"""One source for the fit's options: :class:`FitConfig`'s declarations give ``doodle fit``'s flags, the batch
manifest's keys, the checks, and one rule for the size a scene is loaded at."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from doodle.batch.manifest import OPTIONS
from doodle.cli import cli
from doodle.errors import DoodleError
from doodle.fit.config import GROUPS, FitConfig, cli_flag, config_fields, manifest_key


def _fit_params() -> dict:
    return {p.name: p for p in cli.commands["fit"].params}


def test_every_field_is_a_flag_or_documented_as_internal():
    params = _fit_params()
    for f in config_fields():
        m = f.metadata
        assert m["group"] in GROUPS and len(m["help"]) > 20, f.name
        if m["internal"]:
            assert f.name not in params and len(m["internal"]) > 10, f.name
            continue
        assert f.name in params, f"{f.name} is neither a `doodle fit` option nor marked internal"
        p = params[f.name]
        assert cli_flag(f) in p.opts and p.help == m["help"] and p.group == m["group"]
        default = p.default if f.metadata["kind"] != "count" else p.default
        assert default == f.default or str(default) == str(f.default), (f.name, p.default, f.default)


def test_the_help_lists_the_options_by_group():
    r = CliRunner().invoke(cli, ["fit", "--help"])
    assert r.exit_code == 0
    headings = [ln.strip() for ln in r.output.splitlines() if ln.strip().endswith("options:")]
    assert headings == ["Discovery options:", "Abstraction options:", "Outline options:", "Optimiser options:",
                        "Run options:"]


def test_the_manifest_takes_the_fit_options_by_name():
    for f in config_fields():
        key = manifest_key(f)
        if f.metadata["manifest"]:
            assert key in OPTIONS and OPTIONS[key].default == f.default and OPTIONS[key].help == f.metadata["help"]
        else:
            assert key not in OPTIONS or key == "size", key  # the manifest's size is the exported views'
    assert "fit_size" in OPTIONS and OPTIONS["size"].default == 512


def test_a_manifest_value_reaches_the_fit(tmp_path):
    from doodle.batch.manifest import load_manifest

    (tmp_path / "objects.toml").write_text('[defaults]\nthin = 0.1\nfit_size = 128\n[[objects]]\nscene = "a"\n'
                                           'texture = false\nmin_gain = 2\n', encoding="utf-8")
    with pytest.raises(DoodleError, match="min_gain must be between 0 and 1"):
        load_manifest(tmp_path / "objects.toml")
    (tmp_path / "objects.toml").write_text('[defaults]\nthin = 0.1\nfit_size = 128\n[[objects]]\nscene = "a"\n'
                                           'texture = false\nmin_gain = 0.002\n', encoding="utf-8")
    o = load_manifest(tmp_path / "objects.toml").objects[0].options
    cfg = FitConfig(**{f.name: o[manifest_key(f)] for f in config_fields() if f.metadata["manifest"]})
    assert (cfg.thin, cfg.size, cfg.texture, cfg.discovery_min_gain) == (0.1, 128, False, 0.002)


@pytest.mark.parametrize("kw, flag", [(dict(thin=0.9), "--thin"), (dict(curves=-1), "--curves"),
                                      (dict(evidence_voxels=8), "--evidence-voxels"), (dict(outline="box"), "--outline"),
                                      (dict(discovery_min_gain=2.0), "--min-gain"), (dict(seed=1.5), "--seed")])
def test_check_names_the_flag(kw, flag):
    with pytest.raises(DoodleError, match=flag):
        FitConfig(**kw).check()


def test_the_cli_and_the_batch_load_a_scene_at_one_size(tmp_path, monkeypatch):
    """The scene is loaded at the finer of the working and evidence sizes, whoever runs the fit."""
    import doodle.scenes
    from doodle.batch.job import Task, run_object
    from doodle.batch.manifest import OPTIONS as opts

    sizes = []

    def loading(root, split, size):
        sizes.append(size)
        raise DoodleError("stop here")

    monkeypatch.setattr(doodle.scenes, "load_scene_at_size", loading)
    (tmp_path / "scene").mkdir()
    r = CliRunner().invoke(cli, ["fit", str(tmp_path / "scene"), "-o", str(tmp_path / "x.doodle"), "--size", "700",
                                 "--evidence-size", "300"])
    assert r.exit_code == 2 and "stop here" in r.output
    options = {k: o.default for k, o in opts.items()}
    options.update(fit_size=700, evidence_size=300)
    record = run_object(Task("a", str(tmp_path / "scene"), options, str(tmp_path / "out"), "f"))
    assert record["status"] == "error" and "stop here" in record["error"]
    assert sizes == [700, 700] == [FitConfig(size=700, evidence_size=300).load_size] * 2
