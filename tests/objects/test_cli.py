"""`entangle-bench objects list|show|decompose`, run in-process."""

import trimesh

from entangle_bench import objects
from entangle_bench.cli import main


def test_list_shows_every_object(capsys):
    assert main(["objects", "list"]) == 0
    out = capsys.readouterr().out
    for name in objects.names():
        assert name in out


def test_show_prints_numbers_and_writes_a_png(tmp_path, capsys):
    out_png = tmp_path / "tree.png"
    code = main(["objects", "show", "eight_branch_tree", "--set", "branch_length_m=0.06",
                 "--out", str(out_png)])
    assert code == 0
    out = capsys.readouterr().out
    assert "phi_T" in out and "parts           10" in out
    assert out_png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert out_png.stat().st_size > 10_000


def test_show_unknown_name_lists_known_ones(capsys):
    assert main(["objects", "show", "teapot", "--out", "x.png"]) == 2
    err = capsys.readouterr().err
    assert "teapot" in err and "eight_branch_tree" in err


def test_show_bad_override_is_a_clear_error(capsys):
    assert main(["objects", "show", "sphere", "--set", "diameter_m=-1"]) == 2
    assert "diameter_m" in capsys.readouterr().err


def test_decompose_primitive_needs_nothing(capsys):
    assert main(["objects", "decompose", "cube"]) == 0
    assert "no decomposition needed" in capsys.readouterr().out


def test_decompose_shipped_object_is_a_cache_hit(capsys):
    assert main(["objects", "decompose", "dexnet_endstop_holder"]) == 0
    assert "cache hit" in capsys.readouterr().out


def test_decompose_a_mesh_file_then_hit_the_cache(tmp_path, capsys):
    path = tmp_path / "ring.obj"
    trimesh.creation.annulus(r_min=0.02, r_max=0.03, height=0.01, sections=12).export(path)
    args = ["objects", "decompose", str(path), "--cache-dir", str(tmp_path / "cache"),
            "--set", "coacd.max_convex_hull=6", "--set", "coacd.resolution=400"]
    assert main(args) == 0
    captured = capsys.readouterr()
    assert "computed" in captured.out and "coacd ring" in captured.err  # progress on stderr
    assert main(args) == 0
    assert "cache hit" in capsys.readouterr().out


def test_decompose_millimetre_file_is_a_clear_error(tmp_path, capsys):
    path = tmp_path / "mm.obj"
    trimesh.creation.box(extents=[50.0, 50.0, 50.0]).export(path)
    assert main(["objects", "decompose", str(path)]) == 2
    assert "millimetres" in capsys.readouterr().err
