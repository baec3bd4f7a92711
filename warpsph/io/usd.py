"""Particle cache as USD value clips: ``NAME.usdc`` + ``NAME_clips/frame.NNNNNN.usdc``.

Each frame is its own small clip layer, written once and renamed into place; the top-level
``NAME.usdc`` (a ``UsdGeom.Points`` prim ``/Particles`` with template clip metadata) is rewritten
after each frame. Memory stays flat over long runs and a killed run leaves a stage that opens.

Time codes are frame indices (0, 1, 2, ...); the simulation time [s] and step of each frame are
the time-sampled attributes ``warpsph:time`` and ``warpsph:step`` on ``/Particles``.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from warpsph.fields import mean_stress, von_mises, voigt_to_tensor

PRIM_PATH = "/Particles"
TIME_CODES_PER_SECOND = 24.0  # playback rate in frames per wall-clock second; not simulation time
_MANIFEST = "manifest.usdc"
_TEMPLATE = "frame.{:06d}.usdc"  # USD clip templates need the dot


def _pxr():
    try:
        from pxr import Sdf, Usd, UsdGeom, Vt
    except ImportError as e:
        raise ImportError("USD output needs the usd-core package: pip install usd-core") from e
    return Sdf, Usd, UsdGeom, Vt


class UsdParticleCache:
    """Writes particle frames to ``DIRECTORY/NAME.usdc`` (see module docstring).

    Primvars (vertex interpolation, float32): (N,) -> ``float[]``; (N,3) -> ``vector3f[]``;
    (N,6) symmetric tensors in Voigt order -> two ``float[]`` primvars ``NAME_mean`` (trace/3)
    and ``NAME_von_mises`` (sqrt(3 J2)). ``radius`` [m] sets the constant ``widths`` = 2 radius.
    ``resume_step`` keeps the frames with step <= resume_step and continues after them.
    """

    def __init__(self, directory, *, name: str = "particles", radius: float, up_axis: str = "Y",
                 resume_step: int | None = None):
        self._Sdf, self._Usd, self._UsdGeom, self._Vt = _pxr()
        self.path = Path(directory) / f"{name}.usdc"
        self.clip_dir = Path(directory) / f"{name}_clips"
        self.radius = float(radius)
        self.up_axis = up_axis
        self._decls: dict[str, tuple[str, str | None]] = {}  # attribute -> (type, interpolation)
        self._count = 0  # frames in the cache
        self.clip_dir.mkdir(parents=True, exist_ok=True)
        if resume_step is not None:
            self._count = self._kept_frames(int(resume_step))
            if self._count and (self.clip_dir / _MANIFEST).exists():
                layer = self._Sdf.Layer.OpenAsAnonymous(str(self.clip_dir / _MANIFEST))
                for spec in layer.GetPrimAtPath(PRIM_PATH).attributes:
                    interp = spec.GetInfo("interpolation") if spec.HasInfo("interpolation") else None
                    self._decls[spec.name] = (str(spec.typeName), interp)
        if self._count:
            self._write_top()
        else:
            self.path.unlink(missing_ok=True)  # before the clips go: no stage may point at deleted clips
        for path in self.clip_dir.glob("*.usdc"):  # later frames and leftovers of killed writes
            if path.name.startswith("tmp_") or (path.name.startswith("frame.")
                                                and int(path.name.split(".")[1]) >= self._count):
                path.unlink()

    def _kept_frames(self, resume_step: int) -> int:
        """Length of the run of clips 0, 1, ... whose step is <= resume_step."""
        count = 0
        while (path := self.clip_dir / _TEMPLATE.format(count)).exists():
            layer = self._Sdf.Layer.OpenAsAnonymous(str(path), metadataOnly=True)
            if layer is None or layer.customLayerData.get("warpsph:step", resume_step + 1) > resume_step:
                break
            count += 1
        return count

    def _primvars(self, primvars: dict[str, np.ndarray], n: int) -> dict[str, np.ndarray]:
        """Expand (N,6) tensors to derived scalars; check shapes."""
        out = {}
        for name, value in primvars.items():
            value = np.asarray(value)
            if value.shape[:1] != (n,) or value.shape[1:] not in ((), (3,), (6,)):
                raise ValueError(f"primvar {name!r}: shape {value.shape}, expected ({n},), ({n},3) or ({n},6)")
            if value.shape[1:] == (6,):
                tensor = voigt_to_tensor(value)
                out[f"{name}_mean"] = mean_stress(tensor)
                out[f"{name}_von_mises"] = von_mises(tensor)
            else:
                out[name] = value
        return out

    def write_frame(self, step: int, time: float, position: np.ndarray, primvars: dict[str, np.ndarray],
                    ids: np.ndarray | None = None) -> None:  # fmt: skip
        """Write frame ``step`` at simulation ``time`` [s]: positions (N,3) [m], primvars (see class) and the
        particles' ids (N,) (``UsdGeom.Points`` ``ids``: a particle keeps its id across frames and phases)."""
        Sdf, Vt = self._Sdf, self._Vt
        p = np.ascontiguousarray(position, dtype=np.float32)
        lo, hi = p.min(axis=0) - self.radius, p.max(axis=0) + self.radius
        values = {
            "points": ("point3f[]", None, Vt.Vec3fArray.FromNumpy(p)),
            "extent": ("float3[]", None, Vt.Vec3fArray.FromNumpy(np.stack([lo, hi]))),
            "warpsph:time": ("double", None, float(time)),
            "warpsph:step": ("int64", None, int(step)),
        }
        if ids is not None:
            values["ids"] = ("int64[]", None, Vt.Int64Array.FromNumpy(np.ascontiguousarray(ids, dtype=np.int64)))
        for name, value in self._primvars(primvars, p.shape[0]).items():
            value = np.ascontiguousarray(value, dtype=np.float32)
            array = Vt.Vec3fArray.FromNumpy(value) if value.ndim == 2 else Vt.FloatArray.FromNumpy(value)
            values[f"primvars:{name}"] = ("vector3f[]" if value.ndim == 2 else "float[]", "vertex", array)

        index = self._count
        layer = self._layer({k: v[:2] for k, v in values.items()})
        for name, (_, _, value) in values.items():
            layer.SetTimeSample(Sdf.Path(f"{PRIM_PATH}.{name}"), float(index), value)
        layer.customLayerData = {"warpsph:step": int(step), "warpsph:time": float(time), "warpsph:frame": index}
        self._export(layer, self.clip_dir / _TEMPLATE.format(index))

        new = {k: v[:2] for k, v in values.items() if k not in self._decls}
        if new:
            self._decls.update(new)
            self._export(self._layer(self._decls), self.clip_dir / _MANIFEST)
        self._count = index + 1
        self._write_top()

    def _layer(self, decls: dict[str, tuple[str, str | None]]):
        """Anonymous layer with the Points prim and the declared (valueless) attributes."""
        Sdf = self._Sdf
        layer = Sdf.Layer.CreateAnonymous(".usdc")
        prim = Sdf.CreatePrimInLayer(layer, PRIM_PATH)
        prim.specifier, prim.typeName = Sdf.SpecifierDef, "Points"
        for name, (type_name, interp) in decls.items():
            spec = Sdf.AttributeSpec(prim, name, Sdf.ValueTypeNames.Find(type_name),
                                     declaresCustom=name.startswith("warpsph:"))
            if interp:
                spec.SetInfo("interpolation", interp)
        layer.defaultPrim = PRIM_PATH[1:]
        return layer

    def _write_top(self) -> None:
        """Rewrite NAME.usdc: stage metadata, constant widths, template clips over frames 0..count-1."""
        Usd, UsdGeom = self._Usd, self._UsdGeom
        stage = Usd.Stage.Open(self._layer(self._decls))
        stage.SetStartTimeCode(0)
        stage.SetEndTimeCode(self._count - 1)
        stage.SetTimeCodesPerSecond(TIME_CODES_PER_SECOND)
        stage.SetFramesPerSecond(TIME_CODES_PER_SECOND)
        UsdGeom.SetStageUpAxis(stage, self.up_axis)
        UsdGeom.SetStageMetersPerUnit(stage, 1.0)
        points = UsdGeom.Points(stage.GetPrimAtPath(PRIM_PATH))
        points.CreateWidthsAttr([2.0 * self.radius])
        points.SetWidthsInterpolation(UsdGeom.Tokens.constant)
        clips = Usd.ClipsAPI(points.GetPrim())
        rel = f"./{self.clip_dir.name}/"
        clips.SetClipPrimPath(PRIM_PATH)
        clips.SetClipManifestAssetPath(rel + _MANIFEST)
        clips.SetClipTemplateAssetPath(rel + "frame.######.usdc")
        clips.SetClipTemplateStartTime(0)
        clips.SetClipTemplateEndTime(self._count - 1)
        clips.SetClipTemplateStride(1)
        stage.GetRootLayer().customLayerData = {
            "warpsph:timeCodes": "frame index; simulation time [s] is attribute warpsph:time"}
        self._export(stage.GetRootLayer(), self.path)

    @staticmethod
    def _export(layer, path: Path) -> None:
        tmp = path.with_name(f"tmp_{path.name}")  # same extension: the format follows it
        try:
            if not layer.Export(str(tmp)):
                raise OSError(f"could not write {tmp}")
            os.replace(tmp, path)
        finally:
            tmp.unlink(missing_ok=True)

    def close(self) -> None:
        """Nothing is held open; kept for symmetry with ResultsWriter."""

    def __enter__(self) -> UsdParticleCache:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
