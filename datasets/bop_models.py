"""The object models of a BOP dataset (:class:`~catpose.datasets.bop.BOP`): meshes in mm, the
normalisation into catpose's object frame (configured model axes, bounding-box centre moved onto a
continuous-symmetry axis, unit bounding sphere), ``models_info.json`` symmetries (continuous axes,
discrete transforms in the normalised frame) and the sampled instance templates.

:class:`BopModels` is a mixin of :class:`~catpose.datasets.bop.BOP`; it reads the loader's
``layout``, ``model_axes``, ``object_axes``, ``symmetric``, ``template_points``, ``seed`` and caches.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from catpose.datasets.bop_layout import continuous_symmetry_origin
from catpose.datasets.meshio import R_template_file, read_mesh, sampled_template
from catpose.errors import DatasetError
from catpose.geometry import apply_R, make_T, norm3, normalize_to_unit_sphere, small_matmul, unit3
from catpose.types import Template


class BopModels:
    """Models, normalisation and symmetries of a BOP dataset's objects (mixin of ``BOP``)."""

    def model_mm(self, obj_id: int) -> tuple[np.ndarray, np.ndarray]:
        """Model vertices (V, 3) in mm (BOP model frame) and triangles (F, 3)."""
        if obj_id not in self._models_mm:
            self._models_mm[obj_id] = read_mesh(self.layout.model(obj_id))
        return self._models_mm[obj_id]

    def normalisation(self, obj_id: int) -> tuple[np.ndarray, np.ndarray, float]:
        """``(R_object_model (3, 3), centre (3,) mm, scale mm)``: ``p_object = (R p_model - centre) / scale``.

        The centre is the bounding-box centre, moved onto the continuous-symmetry axis (the
        point of the axis nearest to it, BOP's ``offset`` included) when the object has one,
        so that a spin about the axis leaves the object origin in place.
        """
        if obj_id not in self._norm:
            R = R_template_file(*self.object_axes.get(obj_id, self.model_axes))
            v, _ = self.model_mm(obj_id)
            vr = apply_R(R, v)
            _, centre, scale = normalize_to_unit_sphere(vr)
            cont = self.continuous_symmetries(obj_id)
            if cont:
                rotated = [
                    {
                        "axis": apply_R(R, np.asarray(e["axis"], float)),
                        "offset": apply_R(R, np.asarray(e["offset"], float)),
                    }
                    for e in cont
                ]
                centre = continuous_symmetry_origin(rotated, centre)
                scale = float(norm3(vr - centre).max())
            self._norm[obj_id] = (R, centre, scale)
        return self._norm[obj_id]

    def models_info(self, obj_id: int) -> dict:
        """The object's ``models_info.json`` entry (empty when the file or entry is absent)."""
        path = self.layout.models_info()
        if not path.is_file():
            return {}
        entry = self._read_json(path).get(str(obj_id))
        if entry is None:
            self._warn_no_info(path, obj_id)
            return {}
        return entry

    def continuous_symmetries(self, obj_id: int) -> list[dict]:
        """Every ``symmetries_continuous`` entry, ``{"axis": (3,), "offset": (3,) mm}`` (model frame)."""
        out = []
        for k, e in enumerate(self.models_info(obj_id).get("symmetries_continuous") or []):
            try:
                axis = np.asarray(e["axis"], float).reshape(3)
                offset = np.asarray(e.get("offset", (0.0, 0.0, 0.0)), float).reshape(3)
            except (KeyError, TypeError, ValueError):
                raise DatasetError(
                    f"{self.layout.models_info()}: symmetries_continuous[{k}] of object {obj_id} "
                    "needs axis and offset (3 numbers each)"
                ) from None
            if not np.isfinite(axis).all() or norm3(axis) == 0 or not np.isfinite(offset).all():
                raise DatasetError(
                    f"{self.layout.models_info()}: symmetries_continuous[{k}] of object {obj_id} "
                    "has a zero or non-finite axis or offset"
                )
            out.append({"axis": axis.tolist(), "offset": offset.tolist()})
        return out

    def symmetry_axis(self, obj_id: int, category: str) -> np.ndarray | None:
        """Main axis (3,) in the object frame: the category entry, else ``models_info.json``."""
        if category in self.symmetric:
            return self.symmetric[category]
        sym = self.continuous_symmetries(obj_id)
        if not sym:
            return None
        R, _, _ = self.normalisation(obj_id)
        return unit3(apply_R(R, np.asarray(sym[0]["axis"], float)))

    def _warn_no_info(self, info_path: Path, obj_id: int) -> None:
        """Warn once per object that ``models_info.json`` lacks it (then it is non-symmetric)."""
        if obj_id not in self._warned_no_info:
            self._warned_no_info.add(obj_id)
            warnings.warn(
                f"{info_path} has no entry for object {obj_id}; it is scored as non-symmetric: add "
                f'"{obj_id}" there, or set dataset.symmetric.<category>=[x, y, z] if it is symmetric',
                stacklevel=2,
            )

    def discrete_symmetries(self, obj_id: int) -> tuple[np.ndarray, ...]:
        """``symmetries_discrete`` of ``models_info.json`` as (4, 4) transforms of the normalised
        object frame: ``S_object = N S_model N^-1`` with ``N`` the normalisation
        ``p_object = (R p_model - centre) / scale`` (BOP gives S_model with t in mm)."""
        info_path = self.layout.models_info()
        entries = self.models_info(obj_id).get("symmetries_discrete") or []
        R, centre, scale = self.normalisation(obj_id)
        N = make_T(R / scale, -centre / scale)
        N_inv = make_T(scale * R.T, apply_R(R.T, centre))  # p_model = R^T (scale p_object + centre)
        out = []
        for k, entry in enumerate(entries):
            S = np.asarray(entry, float).reshape(-1)
            if S.size != 16 or not np.isfinite(S).all():
                raise DatasetError(f"{info_path}: symmetries_discrete[{k}] of object {obj_id} is not 16 numbers")
            out.append(small_matmul(small_matmul(N, S.reshape(4, 4)), N_inv))
        return tuple(out)

    @staticmethod
    def _obj_id(instance_id: str) -> int:
        try:
            return int(str(instance_id).rsplit("_", 1)[-1])
        except ValueError:
            raise DatasetError(f"BOP instance id {instance_id!r} is not obj_XXXXXX") from None

    def instance_model(self, category: str, instance_id: str) -> Template:
        obj_id = self._obj_id(instance_id)
        if obj_id not in self._instances:
            v_mm, f = self.model_mm(obj_id)
            R, centre, scale = self.normalisation(obj_id)
            v = (apply_R(R, v_mm) - centre) / scale
            self._instances[obj_id] = sampled_template(
                v,
                f,
                f"bop/obj_{obj_id:06d}",
                category,
                self.template_points,
                self.seed,
                self.symmetry_axis(obj_id, category),
            )
        return self._instances[obj_id]
