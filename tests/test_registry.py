"""The one registry mechanism: decorator registration, duplicates, unknown names, tags; every registry uses it."""

import pytest

from entangle_bench.errors import DuplicateNameError, UnknownNameError
from entangle_bench.objects.catalog import OBJECTS
from entangle_bench.presets import PRESETS
from entangle_bench.registry import Registry
from entangle_bench.rods.representations import REPRESENTATIONS
from entangle_bench.suite import TASKS
from entangle_bench.suites import SUITES


def test_decorator_registers_next_to_the_factory_and_returns_it():
    shapes = Registry("shape")

    @shapes.register("disc", tags=("flat",))
    def make_disc():
        """A flat disc."""
        return "disc"

    @shapes.register("ball", description="a round ball")
    def make_ball():
        return "ball"

    assert make_disc() == "disc"  # the decorator hands the factory back unchanged
    assert shapes.get("disc") is make_disc and shapes["ball"] is make_ball
    assert shapes.entry("disc").description == "A flat disc." and shapes.entry("ball").description == "a round ball"
    assert shapes.names() == ["ball", "disc"] and shapes.names(tag="flat") == ["disc"]
    assert "disc" in shapes and "cube" not in shapes and len(shapes) == 2 and list(shapes) == ["disc", "ball"]


def test_duplicates_raise_and_unknown_names_list_the_known_ones():
    shapes = Registry("shape")
    shapes.add("disc", 1)
    with pytest.raises(DuplicateNameError, match="shape 'disc' is already registered"):
        shapes.add("disc", 2)
    assert shapes.get("disc") == 1
    with pytest.raises(UnknownNameError, match="unknown shape 'cube'; known: disc") as info:
        shapes.get("cube")
    assert info.value.known == ["disc"] and isinstance(info.value, KeyError)


@pytest.mark.parametrize(
    "registry, kind, some",
    [
        (TASKS, "task", "top_drape/eight_branch_tree"),
        (OBJECTS, "object", "eight_branch_tree"),
        (PRESETS, "preset", "balanced"),
        (SUITES, "suite", "default"),
        (REPRESENTATIONS, "representation", "ball"),
    ],
)
def test_every_registry_uses_the_one_mechanism(registry, kind, some):
    assert isinstance(registry, Registry) and registry.kind == kind
    assert some in registry.names()
    with pytest.raises(DuplicateNameError):
        registry.add(some, registry.get(some))
    with pytest.raises(UnknownNameError, match=some):
        registry.get("no_such_name")


def test_task_entries_hold_their_factory_and_config_type():
    assert TASKS.names(tag="stability") == ["probe/curl_in_air"]
    assert set(TASKS.names(tag="benchmark")) == {f"top_drape/{n}" for n in OBJECTS.names()}
    assert set(TASKS.names(tag="pullout")) == {f"pullout/{n}" for n in OBJECTS.names()}
    meshes = OBJECTS.names(tag="mesh")
    assert set(TASKS.names(tag="mesh")) == {f"{family}/{n}" for family in ("top_drape", "pullout") for n in meshes}
    probe, tree = TASKS.get("probe/curl_in_air"), TASKS.get("top_drape/eight_branch_tree")
    assert probe.config_type is not tree.config_type and probe.make_environment is not tree.make_environment
    assert probe.domain == "probe" and tree.domain == "top_drape"
