"""Reading scenes from TOML files (format: ``docs/scenes.md``).

The file mirrors the dataclasses of :mod:`warpsph.scene`, table for dataclass and key for field (nested
dataclasses such as ``drainage`` are inline tables); every problem raises
:class:`~warpsph.errors.SceneError` naming its key path. One rule goes beyond the dataclasses: a material
gives either ``density`` (the saturated mixture) or ``grain_density``, from which ``density`` is set to
the mixture (1 − n) ρ_s + n ρ_w.
"""

from __future__ import annotations

import re
import tomllib
import typing
from collections.abc import Mapping
from pathlib import Path

from warpsph.errors import SceneError
from warpsph.scene import Scene
from warpsph.material_check import mixture_density
from warpsph.scene_check import validate_scene
from warpsph.scene_types import field_hints, from_table


def load_scene(path: str | Path, overrides: Mapping[str, object] | None = None) -> Scene:
    """Read, parse and validate the scene file ``path``; the scene is named after the file's stem
    unless the file sets ``name``. ``overrides`` as for :func:`parse_scene`."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise SceneError("", f"cannot read scene file {path}: {exc.strerror or exc}") from None
    try:
        text = data.decode("utf-8-sig")  # a byte-order mark, which some editors write, is dropped
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        column = exc.start - (data.rfind(b"\n", 0, exc.start) + 1) + 1
        raise SceneError("", f"the file is not UTF-8 text: byte 0x{data[exc.start]:02x} at line {line}, "
                         f"column {column} (save it as UTF-8)") from None  # fmt: skip
    if not text.strip():
        raise SceneError("", "the file is empty; a scene needs at least [materials.<name>] and [[bodies]] "
                         "(docs/scenes.md)")  # fmt: skip
    return parse_scene(text, name=path.stem, overrides=overrides)


def parse_scene(text: str, name: str = "scene", overrides: Mapping[str, object] | None = None) -> Scene:
    """Parse and validate the TOML scene ``text``; ``name`` applies unless the text sets ``name``.

    ``overrides`` maps dotted keys to values set before parsing, as if the file held them
    (:func:`apply_overrides`), so they go through the same checks and errors name the same keys.
    The returned scene keeps ``text`` as its ``source_text``, with the overrides appended as comments.
    """
    try:
        document = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError("", f"TOML syntax error: {_syntax_error(str(exc), text)}") from None
    if overrides:
        apply_overrides(document, overrides)
        text += "".join(f"\n# override: {key} = {value!r}" for key, value in overrides.items()) + "\n"
    scene = from_table(Scene, "", document, exclude=("source_text",))
    _set_mixture_densities(scene, document)
    if "name" not in document:
        scene.name = name
    scene.source_text = text
    validate_scene(scene)
    return scene


def _syntax_error(message: str, text: str) -> str:
    """tomllib's message on one line; for a key given twice, which it reports as "Cannot overwrite a
    value", the key and both lines."""
    message = " ".join(message.split())
    found = re.search(r"^Cannot (?:overwrite|declare) .*\(at line (\d+), column \d+\)$", message)
    if found is None:
        return message
    lines = text.splitlines()
    number = int(found.group(1))
    key = lines[number - 1].split("=", 1)[0].strip().strip("[]").strip() if number <= len(lines) else ""
    if not key:
        return message
    leaf = key.rsplit(".", 1)[-1]
    earlier = [i + 1 for i, line in enumerate(lines[: number - 1])
               if line.split("=", 1)[0].strip().strip("[]").strip().rsplit(".", 1)[-1] == leaf]  # fmt: skip
    where = f" (at line {number}{f'; first at line {earlier[-1]}' if earlier else ''})"
    return f"the key {key!r} is given twice in one table{where}"


def apply_overrides(document: dict, overrides: Mapping[str, object]) -> dict:
    """Set each dotted key of ``overrides`` in the parsed TOML ``document`` (in place; returned).

    Keys are the key paths of docs/scenes.md: ``simulation.dx``, ``pressure.tolerance``,
    ``materials.soil.youngs_modulus``; entries of ``[[bodies]]``, ``[[boundaries]]``, ``[[loads]]``
    and ``[[probes]]`` are picked by name (``loads.top.traction``). Missing tables are created; an
    entry that does not exist raises :class:`SceneError` naming the key.
    """
    arrays = {n for n, hint in field_hints(Scene).items() if typing.get_origin(hint) is list}
    for key, value in overrides.items():
        parts = key.split(".")
        if not all(parts):
            raise SceneError(key, "expected a dotted key path such as simulation.dx")
        node = document
        for depth, part in enumerate(parts[:-1]):
            if isinstance(node, list):
                node = _entry_named(node, ".".join(parts[:depth]), part)
            elif isinstance(node, dict):
                node = node.setdefault(part, [] if depth == 0 and part in arrays else {})
            else:
                raise SceneError(".".join(parts[:depth]), f"not a table, so {key} cannot be set")
        if isinstance(node, list):
            raise SceneError(key, f"name a key inside an entry, e.g. {key}.<key>")
        if not isinstance(node, dict):
            raise SceneError(".".join(parts[:-1]), f"not a table, so {key} cannot be set")
        node[parts[-1]] = value
    return document


def _entry_named(entries: list, section: str, name: str) -> dict:
    """The entry of the ``[[section]]`` array called ``name`` (unnamed entries are e.g. "body0")."""
    cls = typing.get_args(field_hints(Scene)[section])[0]
    default = cls.__name__.lower()
    names = [t.get("name", f"{default}{i}") if isinstance(t, dict) else None for i, t in enumerate(entries)]
    if name not in names:
        known = ", ".join(f'"{n}"' for n in names if n is not None) or "none"
        raise SceneError(f"{section}.{name}", f"no entry named \"{name}\"; entries: {known}")
    return entries[names.index(name)]


def _set_mixture_densities(scene: Scene, document: dict) -> None:
    """A material with ``grain_density`` gets ``density`` = (1 − n) ρ_s + n ρ_w; it may not give both."""
    for key, material in scene.materials.items():
        if material.grain_density is None:
            continue
        if "density" in document["materials"][key]:
            raise SceneError(
                f"materials.{key}.grain_density", "give either density (the mixture) or grain_density, not both"
            )
        material.density = mixture_density(material)
