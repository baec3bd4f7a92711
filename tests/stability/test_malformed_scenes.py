"""Malformed scenes (issue 6, item 10) through the command line: exit code 2 with one line on stderr,
never a traceback, never a hang.

- **Table**: every case of ``test_scene_errors.BAD_CASES`` (85 distinct malformed scenes) written to a
  file and checked by ``warpsph validate`` (the command line's ``main``, in process): exit code 2 and
  one stderr line ``warpsph: error: <file>: <key path>: <message>`` naming the case's key path.
  A sample of them also through ``python -m warpsph validate`` in a subprocess (the console path,
  with a timeout).
- **Generated** (hypothesis): the same base scene with 1 to 3 mutations — a value replaced by one of
  another type or out of range, a key removed, an unknown key added — anywhere in its tables: the
  exit code is 0 (the mutation happened to be valid) or 2 with exactly one line; any other exception
  escapes ``main`` and fails the test; each validation must end within 20 s.
"""

import contextlib
import io
import json
import math
import signal
import subprocess
import sys
import tomllib

import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from test_scene_errors import BAD_CASES, BASE

from warpsph.cli import EXIT_BAD_INPUT, main

TIME_LIMIT = 20
"""Seconds a validation may take before it counts as a hang."""


def toml_key(key: str) -> str:
    return key if key and all(c.isalnum() or c in "_-" for c in key) else json.dumps(key)


def toml_value(value) -> str:
    """A TOML value (inline tables and arrays; JSON string escapes are TOML's)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") if math.isinf(value) else repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{toml_key(k)} = {toml_value(v)}" for k, v in value.items()) + " }"
    return "[" + ", ".join(toml_value(v) for v in value) + "]"


def toml_text(table: dict, prefix: str = "") -> str:
    """TOML text of a parsed scene: scalars, then sub-tables, then arrays of tables."""
    def is_table_array(v):
        return isinstance(v, list) and v and all(isinstance(x, dict) for x in v)

    lines = [f"{toml_key(k)} = {toml_value(v)}" for k, v in table.items()
             if not isinstance(v, dict) and not is_table_array(v)]  # fmt: skip
    for k, v in table.items():
        name = prefix + toml_key(k)
        if isinstance(v, dict):
            lines += [f"[{name}]", toml_text(v, name + ".")]
        elif is_table_array(v):
            for item in v:
                lines += [f"[[{name}]]", toml_text(item, name + ".")]
    return "\n".join(lines)


def validate(path) -> tuple[int, str]:
    """``warpsph validate path`` in process: (exit code, stderr); a run beyond TIME_LIMIT fails."""
    def hang(signum, frame):
        raise TimeoutError(f"validation of {path} took more than {TIME_LIMIT} s")

    err = io.StringIO()
    previous = signal.signal(signal.SIGALRM, hang)
    signal.alarm(TIME_LIMIT)
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            code = main(["validate", str(path)])
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    return code, err.getvalue()


def assert_one_line_error(code: int, err: str, key: str | None = None) -> None:
    lines = err.strip().splitlines()
    assert code == EXIT_BAD_INPUT, err
    assert len(lines) == 1 and lines[0].startswith("warpsph: error: ") and "Traceback" not in err, err
    if key:
        assert f": {key}: " in lines[0], lines[0]


@pytest.mark.parametrize("case", list(BAD_CASES), ids=list(BAD_CASES))
def test_table_case_through_the_command_line(case, tmp_path):
    make, key = BAD_CASES[case]
    path = tmp_path / "bad.toml"
    path.write_text(make(BASE))
    assert_one_line_error(*validate(path), key)


def test_table_sample_through_the_console(tmp_path):
    """Every fifth case through ``python -m warpsph validate`` in a subprocess."""
    for case in list(BAD_CASES)[::5]:
        make, key = BAD_CASES[case]
        path = tmp_path / "bad.toml"
        path.write_text(make(BASE))
        result = subprocess.run([sys.executable, "-m", "warpsph", "validate", str(path)], capture_output=True,
                                text=True, timeout=60)  # fmt: skip
        assert_one_line_error(result.returncode, result.stderr, key)


def leaf_paths(node, path=()):
    """Key paths of every value in the parsed base scene (list items of arrays of tables by index)."""
    if isinstance(node, dict):
        for k, v in node.items():
            yield path + (k,)
            yield from leaf_paths(v, path + (k,))
    elif isinstance(node, list) and node and all(isinstance(x, dict) for x in node):
        for i, item in enumerate(node):
            yield from leaf_paths(item, path + (i,))


PARSED = tomllib.loads(BASE)
PATHS = list(leaf_paths(PARSED))


def node_at(tree, path):
    for part in path:
        tree = tree[part]
    return tree


TABLES = [p for p in [()] + PATHS if isinstance(node_at(PARSED, p), dict)]
WORDS = ["box", "circle", "polygon", "fixed", "slip", "free", "velocity", "traction", "drained", "inflow",
         "impermeable", "x", "y", "z", "min", "max", "ramp", "table", "step", "cg", "jacobi", "soil", "column",
         "two_set", "collocated", "rk2", "rk4", "float32", "stress_yy", "reaction", "", "inf"]  # fmt: skip
SCALARS = st.one_of(st.booleans(), st.integers(-10**12, 10**12), st.floats(allow_nan=True, allow_infinity=True),
                    st.sampled_from([0.0, -1.0, 1e-12, 1e-300, 1e300, 0.5, 2.0, 1e3]), st.sampled_from(WORDS),
                    st.text(max_size=6))  # fmt: skip
VALUES = st.one_of(SCALARS, st.lists(SCALARS, max_size=4),
                   st.dictionaries(st.sampled_from(["kind", "min", "max", "times", "values", "x"]), SCALARS,
                                   max_size=2))  # fmt: skip
MUTATION = st.one_of(
    st.tuples(st.just("replace"), st.sampled_from(PATHS), VALUES),
    st.tuples(st.just("remove"), st.sampled_from(PATHS), st.none()),
    st.tuples(st.just("add"), st.sampled_from(TABLES), st.tuples(st.sampled_from(["colour", "dxx", "kind2"]), VALUES)),
)


def mutate(tree: dict, mutations) -> dict:
    tree = json.loads(json.dumps(tree, allow_nan=True))  # a deep copy
    for kind, path, value in mutations:
        try:
            if kind == "add":
                node_at(tree, path)[value[0]] = value[1]
            else:
                parent = node_at(tree, path[:-1])
                if kind == "replace":
                    parent[path[-1]] = value
                else:
                    del parent[path[-1]]
        except (KeyError, IndexError, TypeError):
            pass  # an earlier mutation removed or replaced the place
    return tree


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(MUTATION, min_size=1, max_size=3))
def test_generated_scenes_get_one_line_or_pass(tmp_path_factory, mutations):
    path = tmp_path_factory.getbasetemp() / "generated.toml"
    path.write_text(toml_text(mutate(PARSED, mutations)))
    code, err = validate(path)
    event(f"exit code {code}")
    if code != 0:
        assert_one_line_error(code, err)
        event(err.split(": ")[3] if err.count(": ") > 3 else err.strip())
