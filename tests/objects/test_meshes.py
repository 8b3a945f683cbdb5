"""Mesh pipeline: loading checks, repair, CoACD decomposition, its cache and the shipped meshes."""

import dataclasses
import os
import shutil
import subprocess
import sys
from pathlib import Path

import coacd
import numpy as np
import pytest
import trimesh
from scipy.spatial import ConvexHull

from entangle_bench import objects, resources
from entangle_bench.errors import MeshError
from entangle_bench.objects import meshes
from entangle_bench.objects.geometry import ConvexMesh, union_moments

TINY = meshes.CoacdSettings(threshold=0.1, max_convex_hull=8, resolution=500, mcts_iterations=20,
                            mcts_nodes=5, mcts_max_depth=1, max_ch_vertex=16)
DEXNET = [n for n in objects.names() if n.startswith("dexnet_")]


@pytest.fixture(scope="module")
def annulus():
    """A 60 mm ring, 10 mm thick: the smallest non-convex mesh worth decomposing."""
    return trimesh.creation.annulus(r_min=0.02, r_max=0.03, height=0.01, sections=16)


@pytest.fixture
def count_coacd(monkeypatch):
    """Count calls of coacd.run_coacd (still running the real one)."""
    calls = []
    real = coacd.run_coacd

    def counting(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(coacd, "run_coacd", counting)
    return calls


def _is_convex(vertices, faces, tol_m=1e-5):
    """Closed part whose volume is its hull's and whose every vertex lies on the hull surface."""
    part = trimesh.Trimesh(vertices, faces, process=False)
    hull = ConvexHull(vertices)
    depth = np.max(vertices @ hull.equations[:, :3].T + hull.equations[:, 3], axis=1)
    return (part.is_watertight and part.volume == pytest.approx(hull.volume, rel=1e-4)
            and bool(np.all(depth > -tol_m)))


def _union_ratio(parts, mesh_volume):
    convex = [ConvexMesh(f"p{i}", v) for i, (v, _) in enumerate(parts)]
    return union_moments(convex, samples_per_part=3000).volume / mesh_volume


def test_decomposition_covers_the_mesh_and_second_build_hits_the_cache(annulus, tmp_path,
                                                                      count_coacd):
    first = meshes.decompose(annulus, TINY, tmp_path, label="ring")
    assert count_coacd == [1] and not first.from_cache
    assert len(first.parts) >= 3  # a ring needs several convex pieces
    assert all(_is_convex(v, f) for v, f in first.parts)
    assert _union_ratio(first.parts, annulus.volume) == pytest.approx(1.0, abs=0.10)
    second = meshes.decompose(annulus, TINY, tmp_path, label="ring")
    assert count_coacd == [1] and second.from_cache
    assert second.path == first.path
    for (v1, f1), (v2, f2) in zip(first.parts, second.parts, strict=True):
        np.testing.assert_array_equal(v1, v2)
        np.testing.assert_array_equal(f1, f2)
    # other settings are another cache entry
    third = meshes.decompose(annulus, dataclasses.replace(TINY, threshold=0.2), tmp_path, "ring")
    assert count_coacd == [1, 1] and third.path != first.path


def test_interrupted_decomposition_leaves_nothing(annulus, tmp_path, monkeypatch):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(coacd, "run_coacd", interrupted)
    with pytest.raises(KeyboardInterrupt):
        meshes.decompose(annulus, TINY, tmp_path / "cache", label="ring")
    assert not (tmp_path / "cache").exists() or not any((tmp_path / "cache").iterdir())


def test_interrupted_cache_write_leaves_nothing(annulus, tmp_path, monkeypatch):
    box = trimesh.creation.box(extents=[0.02, 0.02, 0.02])
    monkeypatch.setattr(coacd, "run_coacd", lambda *a, **k: [(box.vertices, box.faces)])

    def broken(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(np, "savez_compressed", broken)
    with pytest.raises(KeyboardInterrupt):
        meshes.decompose(annulus, TINY, tmp_path, label="ring")
    assert list(tmp_path.iterdir()) == []


def test_corrupt_cache_file_is_recomputed(tmp_path, monkeypatch):
    box = trimesh.creation.box(extents=[0.02, 0.02, 0.02])
    monkeypatch.setattr(coacd, "run_coacd", lambda *a, **k: [(box.vertices, box.faces)])
    first = meshes.decompose(box, TINY, tmp_path, label="box")
    first.path.write_bytes(b"not a zip")
    again = meshes.decompose(box, TINY, tmp_path, label="box")
    assert not again.from_cache and len(again.parts) == 1


@pytest.mark.parametrize("name", DEXNET)
def test_shipped_meshes_are_precomputed_convex_and_cover_the_mesh(name, monkeypatch):
    def forbidden(*args, **kwargs):
        raise AssertionError("coacd must not run for shipped objects")

    monkeypatch.setattr(coacd, "run_coacd", forbidden)
    params = objects.default_params(name)
    mesh, _ = meshes.load_mesh(params.path, params.scale)
    result = meshes.decompose_object(params, mesh)
    assert result.from_cache and result.path.parent == resources.shipped_cache_dir()
    assert all(_is_convex(v, f) for v, f in result.parts)
    assert _union_ratio(result.parts, mesh.volume) == pytest.approx(1.0, abs=0.10)
    objects.clear_build_cache()
    info = objects.object_info(name)
    assert info.n_parts == len(result.parts)
    assert info.mass_kg == pytest.approx(1000.0 * mesh.volume)  # default density
    assert 0.0 < info.phi_t <= 1.0


def test_cache_key_depends_on_the_file_bytes_scale_and_settings_only(tmp_path):
    ring = trimesh.creation.annulus(r_min=0.02, r_max=0.03, height=0.01, sections=12)
    lf, crlf = tmp_path / "lf.obj", tmp_path / "crlf.obj"
    ring.export(lf)
    crlf.write_bytes(lf.read_bytes().replace(b"\n", b"\r\n"))
    assert meshes.file_digest(lf) == meshes.file_digest(crlf) != meshes.file_digest(lf, scale=0.5)
    key = meshes.cache_key(meshes.file_digest(lf), TINY)
    assert key != meshes.cache_key(meshes.file_digest(lf), dataclasses.replace(TINY, seed=1))
    assert len(key) == 64 and int(key, 16) >= 0


def test_installed_package_writes_new_decompositions_to_the_user_cache(tmp_path, monkeypatch):
    box = trimesh.creation.box(extents=[0.02, 0.02, 0.02])
    path = tmp_path / "ring.obj"
    trimesh.creation.annulus(r_min=0.02, r_max=0.03, height=0.01, sections=12).export(path)
    monkeypatch.setattr(coacd, "run_coacd", lambda *a, **k: [(box.vertices, box.faces)])
    monkeypatch.setattr(resources, "source_tree", lambda: False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    params = meshes.MeshObjectParams(str(path), coacd=TINY)
    mesh, _ = meshes.load_mesh(path)
    first = meshes.decompose_object(params, mesh)
    assert not first.from_cache and first.path.parent == tmp_path / "xdg" / "entangle-bench" / "coacd"
    assert meshes.decompose_object(params, mesh).from_cache


def test_missing_and_empty_files(tmp_path):
    with pytest.raises(MeshError, match="not found"):
        meshes.load_mesh(tmp_path / "nothing.obj")
    empty = tmp_path / "empty.obj"
    empty.write_text("# no geometry\n")
    with pytest.raises(MeshError, match="empty"):
        meshes.load_mesh(empty)


def test_millimetre_mesh_is_caught(tmp_path):
    path = tmp_path / "big.obj"
    trimesh.creation.box(extents=[60.0, 40.0, 20.0]).export(path)  # 60 mm written as 60 "m"
    with pytest.raises(MeshError, match="millimetres"):
        meshes.load_mesh(path)
    mesh, _ = meshes.load_mesh(path, scale=0.001)
    assert mesh.extents.max() == pytest.approx(0.06)


def test_tiny_mesh_is_caught(tmp_path):
    path = tmp_path / "tiny.obj"
    trimesh.creation.box(extents=[0.001, 0.001, 0.001]).export(path)
    with pytest.raises(MeshError, match="implausibly small"):
        meshes.load_mesh(path)


def test_open_mesh_that_cannot_be_closed_is_an_error(tmp_path):
    tube = trimesh.creation.cylinder(radius=0.02, height=0.05, sections=24)
    sides = np.abs(tube.face_normals[:, 2]) < 0.5  # drop both 24-gon caps
    path = tmp_path / "open.obj"
    trimesh.Trimesh(tube.vertices, tube.faces[sides]).export(path)
    with pytest.raises(MeshError, match="not watertight"):
        meshes.load_mesh(path)


def test_fragments_and_cavities_are_repaired(tmp_path):
    outer = trimesh.creation.box(extents=[0.05, 0.05, 0.05])
    cavity = trimesh.creation.box(extents=[0.02, 0.02, 0.02])
    cavity.invert()
    sliver = trimesh.Trimesh([[0.1, 0, 0], [0.11, 0, 0], [0.1, 0.01, 0]], [[0, 1, 2], [0, 2, 1]],
                             process=False)
    loose = trimesh.Trimesh([[0, 0.1, 0], [0.01, 0.1, 0], [0, 0.11, 0]], [[0, 1, 2]],
                            process=False)
    soup = trimesh.util.concatenate([outer, cavity, sliver, loose])
    assert not soup.is_volume
    repaired, notes = meshes.repair_mesh(soup, "soup")
    assert repaired.is_volume
    assert repaired.volume == pytest.approx(0.05**3)
    assert len(notes) == 3
    assert any("fragment" in n for n in notes) and any("cavit" in n for n in notes)
    assert any("open piece" in n for n in notes)


def test_non_watertight_dexnet_mesh_is_repaired():
    name = "dexnet_pawn"
    assert name in objects.names()
    info = objects.object_info(name)
    assert any("fragment" in n for n in info.notes)


def test_convexity_check_catches_a_dent():
    box = trimesh.creation.box(extents=[0.02, 0.02, 0.02])
    assert _is_convex(box.vertices, box.faces)
    dented = box.vertices.copy()
    dented[0] *= 0.5  # pull a corner towards the centre
    assert not _is_convex(dented, box.faces)


def test_stable_pose_puts_a_slab_on_its_broad_face():
    slab = trimesh.creation.box(extents=[0.08, 0.01, 0.05])  # thin along y
    rot = meshes.stable_rotation(slab.vertices, slab.center_mass)
    turned = slab.vertices @ rot.T
    assert np.ptp(turned[:, 2]) == pytest.approx(0.01)


def test_coacd_settings_are_validated():
    with pytest.raises(Exception, match="coacd.threshold"):
        meshes.CoacdSettings(threshold=5.0)


FRESH_CLONE_CHECK = """
import coacd

def forbidden(*args, **kwargs):
    raise AssertionError("coacd ran: a committed cache missed")

coacd.run_coacd = forbidden
import entangle_bench
from entangle_bench import objects
from entangle_bench.objects import meshes

assert entangle_bench.__file__.startswith({root!r}), entangle_bench.__file__
for name in objects.names():
    if objects.is_mesh_object(name):
        params = objects.default_params(name)
        result = meshes.decompose_object(params, meshes.load_mesh(params.path, params.scale)[0])
        assert result.from_cache, name
        objects.object_info(name)
"""


def test_a_fresh_clone_loads_every_mesh_object_from_the_committed_caches(tmp_path):
    """The committed cache keys hit in a clean checkout of HEAD, with an empty user cache; nothing is written."""
    root = Path(__file__).resolve().parents[2]
    if shutil.which("git") is None or subprocess.run(["git", "-C", root, "rev-parse"], capture_output=True).returncode:
        pytest.skip("needs git and a git checkout")
    head = subprocess.run(["git", "-C", root, "rev-parse", "HEAD"], capture_output=True, text=True).stdout.strip()
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "--quiet", "--shared", "--no-checkout", root, clone], check=True)
    subprocess.run(["git", "-C", clone, "checkout", "--quiet", head], check=True)
    env = dict(os.environ, PYTHONPATH=str(clone), XDG_CACHE_HOME=str(tmp_path / "xdg"))
    check = subprocess.run([sys.executable, "-c", FRESH_CLONE_CHECK.format(root=str(clone))], cwd=clone, env=env,
                           capture_output=True, text=True, timeout=300)
    assert check.returncode == 0, check.stderr[-2000:]
    status = subprocess.run(["git", "-C", clone, "status", "--porcelain", "--ignored"], capture_output=True,
                            text=True).stdout
    assert [line for line in status.splitlines() if "__pycache__" not in line] == []
    assert not (tmp_path / "xdg").exists()
