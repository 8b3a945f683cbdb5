"""`entangle-bench describe`: effects, engine stages, collision pairs and envelope warnings."""

from __future__ import annotations

import re

from entangle_bench import effects as fx
from entangle_bench.cli import main
from entangle_bench.scene import build_scene
from entangle_bench.suite import SHORT_SEQUENCE, resolve_config


def described(capsys, *argv: str) -> str:
    assert main(["describe", "eight_branch_tree", *argv]) == 0
    return capsys.readouterr().out


def count(out: str, label: str) -> int:
    return int(re.search(rf"^\s*{label}\s+(\d+)$", out, re.MULTILINE).group(1))


def test_counts_match_the_compiled_model(capsys):
    argv = ["--preset", "fast", "--set", "effects.ground_contact=false"]
    out = described(capsys, *argv)
    config = resolve_config("top_drape/eight_branch_tree", "fast", ["effects.ground_contact=false"])
    model = build_scene(config.scene_config()).model
    pairs = fx.collision_pairs(model)
    assert int(re.search(r"collision pairs: (\d+)", out).group(1)) == len(pairs)
    for kind, n in fx.pair_kinds(model, pairs).items():
        assert count(out, kind) == n
    assert count(out, "filament-ground") == count(out, "object-ground") == 0
    assert re.search(r"ground_contact\s+off", out)
    assert f"nbody={model.nbody} nv={model.nv} ngeom={model.ngeom}" in out
    assert "hub_disk" in out  # the hub never collides
    assert "stability envelope: inside" in out


def test_disabled_stages_and_envelope_warnings_are_printed(capsys):
    out = described(capsys, "--set", "effects.gravity=false", "--set", "gripper.pressure_pa=6e5")
    stages = re.search(r"disabled engine stages: (.*)$", out, re.MULTILINE).group(1)
    assert "gravity" in stages.split(", ")
    assert "warning: the actuated coil is under-resolved" in out


def test_bad_setting_is_a_clean_error(capsys):
    assert main(["describe", "eight_branch_tree", "--set", "effects.friction=sticky"]) == 2
    err = capsys.readouterr().err
    assert "sticky" in err and "sliding" in err


def test_run_prints_envelope_warnings_before_the_run(tmp_path, capsys):
    sets = [arg for item in SHORT_SEQUENCE + ["gripper.pressure_pa=6e5"] for arg in ("--set", item)]
    argv = ["run", "eight_branch_tree", "--preset", "fast", "--workers", "1", "--no-progress"]
    assert main([*argv, "--out", str(tmp_path), *sets]) == 0
    out = capsys.readouterr().out
    warning = out.index("warning: the actuated coil is under-resolved")
    assert warning < out.index("rows:")
    assert out.count("warning: the actuated coil is under-resolved") == 1
