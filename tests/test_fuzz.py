"""Property-based fuzzing of the scene reader: mutated scene tables and --set strings give
a scene or one line of InputError naming the key, never a traceback. Derandomised and
bounded, so it runs the same few hundred cases in CI each time (a few seconds)."""
import copy

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from soilbin.errors import InputError
from soilbin.records.scene import scene_from_table
from soilbin.records.toml_in import read_scene_tables
from conftest import SCENES

RAW = {path: read_scene_tables(path) for path in sorted(SCENES.glob("*.toml"))}
FUZZ = settings(max_examples=300, derandomize=True, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow])

DELETE = object()
values = st.one_of(
    st.just(DELETE), st.booleans(), st.integers(-10**12, 10**12),
    st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=8),
    st.sampled_from([1e300, -1e300, 1e-300, 1e-9, 0.0]),
    st.sampled_from(["x", "-z", "soil", "tool", "base", "force", "jaky", "hex27-bbar", ""]),
    st.lists(st.one_of(st.integers(-3, 3), st.floats(), st.sampled_from(["x", "y", "q"])),
             max_size=4),
    st.dictionaries(st.sampled_from(["of", "model", "E", "boundary", "k"]),
                    st.one_of(st.integers(), st.text(max_size=4)), max_size=2))


def dotted_keys(node, prefix=()):
    """Every key path of a TOML document (list items by index)."""
    items = node.items() if isinstance(node, dict) else enumerate(node)
    for key, value in items:
        yield prefix + (key,)
        if isinstance(value, (dict, list)):
            yield from dotted_keys(value, prefix + (key,))


def mutate(raw, key, value):
    raw = copy.deepcopy(raw)
    *parents, leaf = key
    node = raw
    for part in parents:
        node = node[part]
    if value is DELETE:
        node.pop(leaf, None) if isinstance(node, dict) else node.pop(leaf)
    else:
        node[leaf] = value
    return raw


def names_the_key(message, key):
    words = [str(part) for part in key if not str(part).isdigit()]
    return any(word in message for word in words)


def check(raw, path, key, overrides=()):
    try:
        scene_from_table(raw, path, overrides)
    except InputError as err:
        message = str(err)
        assert message.startswith(f"{path}: ") and "\n" not in message
        assert names_the_key(message, key), (key, message)


@FUZZ
@given(data=st.data())
def test_mutated_scene_tables(data):
    path = data.draw(st.sampled_from(sorted(RAW)))
    raw = RAW[path]
    key = data.draw(st.sampled_from(sorted(dotted_keys(raw), key=str)))
    if data.draw(st.booleans()) and isinstance(raw.get(key[0]), dict):
        key = key[:1] + (data.draw(st.sampled_from(["nosuch", "E", "fix", "steps"])),)
    check(mutate(raw, key, data.draw(values)), path, key)


@FUZZ
@given(data=st.data())
def test_set_strings(data):
    path = data.draw(st.sampled_from(sorted(RAW)))
    raw = RAW[path]
    key = ".".join(map(str, data.draw(st.sampled_from(sorted(dotted_keys(raw), key=str)))))
    text = data.draw(st.one_of(st.text(max_size=12), st.sampled_from(
        ["[]", "{}", "inf", "-inf", "nan", "1e400", "[1, 'a']", '{of="peak_force"}', "0", "-1"])))
    item = data.draw(st.sampled_from([f"{key}={text}", text, f"{key}.{text}=1", f"={text}"]))
    check(raw, path, ("--set",) + tuple(key.split(".")), [item])


@pytest.mark.parametrize("scene, item, accepted", [
    # a residual norm that overflows: the first step "converges" with nothing done
    ("strip-load-von-mises", "loading.magnitude=1e300", "[1e-20, 1e+20]"),
    ("strip-load-von-mises", "loading.magnitude=1e-300", "[1e-20, 1e+20]"),
    # a modulus whose stresses overflow: every step cut, for minutes
    ("tine-2in-90deg", "materials.modified_cap.E=1e300", "[1e-20, 1e+20]"),
    ("tine-2in-90deg", "materials.modified_cap.E=1e-300", "[1e-20, 1e+20]"),
    ("tine-2in-90deg", "tool.interface.k_n=1e300", "[1e-20, 1e+20]"),
    ("retaining-wall-passive", "geostatic.unit_weight=1e300", "[0, 1e+20]"),
    ("retaining-wall-passive", "geostatic.surface=-1e300", "[-1e+06, 1e+06]"),
    # a Newton tolerance below rounding: every step cut, exit 1 after minutes
    ("strip-load-von-mises", "solver.rtol=1e-300", "[1e-14, 1)"),
    ("strip-load-von-mises", "solver.atol=1e-300", "[1e-14, 1)"),
    # sizes gmsh cannot mesh (it aborted the process), and a cell count that overflowed
    ("container-footing", "mesh.edge_size=1e-9", "at least 0.00012"),
    ("tine-2in-90deg", "mesh.element_size=1e-300", "at least"),
])
def test_values_a_run_cannot_honour_are_refused_on_reading(scene, item, accepted):
    path = SCENES / f"{scene}.toml"
    with pytest.raises(InputError) as refused:
        scene_from_table(RAW[path], path, [item])
    message = str(refused.value)
    key = item.split("=")[0]
    assert message.startswith(f"{path}: {key}") and "\n" not in message
    assert accepted in message


@pytest.mark.parametrize("path", sorted(RAW))
def test_every_scene_reads_as_it_is(path):
    scene_from_table(RAW[path], path)
