"""Transform arrays as learning-based registration harnesses write them (RPM-Net, DCP,
learning3d): ``.npy`` / ``.npz`` files of ``B`` rigid transforms, read as per-sample predictions
for ``bench score``.

Shapes: ``(B, 3, 4)`` (``[R | t]``, RPM-Net's ``pred_transforms``) or ``(B, 4, 4)``; a
``(B, 3, 3)`` rotation array with a ``(B, 3)`` translation array (DCP's ``rotation_ab`` /
``translation_ab``) in an ``.npz`` is read too. Each transform maps the observation (the
camera-frame depth points, the harness's *source*) onto the template (its *reference* /
*target*): ``p_template = R p_camera + t``, i.e. catpose's ``T_template_camera``, in the
object-normalised unit of the problems catpose gives (``bench run`` writes them; shapes scaled
to a unit bounding sphere). A harness that estimates the other direction (template onto
observation) passes ``--inverse``.

Sample ids, in the arrays' order: an ``ids`` (or ``sample_ids``) array in the ``.npz``, else a
text file given with ``--ids`` (one id per line, ``#`` comments and blank lines skipped). An id
is a run's ``sample_id`` or ``obs_id``, as in a per-sample CSV.

``.npz`` keys tried for the transforms: ``transforms``, ``pred_transforms``, ``T``,
``T_template_camera``, ``poses``, ``transform``; for rotation + translation: ``R`` /
``rotation_ab`` / ``rotations`` with ``t`` / ``translation_ab`` / ``translations``; optional
``scores`` and ``times`` (seconds per sample).
"""

from __future__ import annotations

import zipfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from catpose.errors import DatasetError, InvalidInputError

TRANSFORM_KEYS = ("transforms", "pred_transforms", "T", "T_template_camera", "poses", "transform")
ROTATION_KEYS = ("R", "rotation_ab", "rotations")
TRANSLATION_KEYS = ("t", "translation_ab", "translations")
ID_KEYS = ("ids", "sample_ids", "sample_id")
SUFFIXES = (".npy", ".npz")


def is_transform_array(path: str | Path) -> bool:
    """Whether ``path`` names a ``.npy`` / ``.npz`` file (read by :func:`read_transform_arrays`)."""
    return Path(path).suffix.lower() in SUFFIXES


def _first(data, keys: Sequence[str]):
    for k in keys:
        if k in data:
            return data[k]
    return None


def _real(a: np.ndarray, where: str, what: str) -> np.ndarray:
    """``a`` as float64 if it holds real numbers (ints or floats); one line naming its type otherwise
    (bool, complex, strings: a wrong array saved, not a pose)."""
    kind = np.asarray(a).dtype.kind
    if kind not in "iuf":
        name = {"b": "true/false values", "c": "complex numbers", "U": "text", "S": "bytes", "O": "objects"}.get(
            kind, str(np.asarray(a).dtype)
        )
        raise InvalidInputError(f"{where}: {what} holds {name} ({np.asarray(a).dtype}); save real numbers (float64)")
    return np.asarray(a, float)


def as_transforms(array: np.ndarray, where: str) -> np.ndarray:
    """``(B, 3, 4)`` or ``(B, 4, 4)`` (a single ``(3, 4)`` / ``(4, 4)`` too) as ``(B, 4, 4)``
    float64 homogeneous transforms; one line naming ``where`` and what is wrong otherwise (the
    shape, the type, a NaN, a last row of a ``(4, 4)`` that is not ``[0, 0, 0, 1]``)."""
    a = np.asarray(array)
    if a.ndim == 2:
        a = a[None]
    if a.ndim != 3 or a.shape[1:] not in ((3, 4), (4, 4)):
        raise InvalidInputError(
            f"{where}: expected transforms of shape (B, 3, 4) or (B, 4, 4), got {a.shape}; "
            "save e.g. np.save(file, pred_transforms) with pred_transforms (B, 3, 4)"
        )
    if len(a) == 0:
        raise InvalidInputError(f"{where}: holds no transforms (shape {a.shape}); save at least one")
    a = _real(a, where, "the transforms")
    bad = np.flatnonzero(~np.isfinite(a).all(axis=(1, 2)))
    if bad.size:
        raise InvalidInputError(f"{where}: transform {int(bad[0])} has a NaN or infinite value")
    if a.shape[1] == 4:  # the last row of a homogeneous transform is fixed: anything else is not a pose
        off = np.flatnonzero(np.abs(a[:, 3, :] - [0.0, 0.0, 0.0, 1.0]).max(axis=1) > 1e-6)
        if off.size:
            k = int(off[0])
            raise InvalidInputError(
                f"{where}: transform {k} has the last row {a[k, 3].tolist()}, not [0, 0, 0, 1]; save (B, 4, 4) "
                "homogeneous transforms [[R, t], [0, 0, 0, 1]] (t in the last column), or (B, 3, 4) [R | t]"
            )
    T = np.zeros((len(a), 4, 4))
    T[:, :3, :] = a[:, :3, :]
    T[:, 3, 3] = 1.0
    return T


def read_ids(path: str | Path) -> list[str]:
    """Sample ids of an ``--ids`` text file: one per line; blank lines and ``#`` comments skipped."""
    path = Path(path)
    if not path.is_file():
        raise DatasetError(f"--ids {path} does not exist; give a text file with one sample id per line")
    ids = [ln.split("#", 1)[0].strip() for ln in path.read_text().splitlines()]
    return [i for i in ids if i]


def read_transform_arrays(path: str | Path, ids: str | Path | Sequence[str] | None = None, inverse: bool = False):
    """Predictions from a ``.npy`` / ``.npz`` transform array (see the module docstring) as the
    per-sample DataFrame :func:`catpose.bench.interop.prediction_io.read_predictions` returns:
    ``sample_id``, ``T`` (``T_template_camera``, (4, 4)), ``score``, ``time``; ``attrs["kind"]``
    is ``"sample"``.

    ``ids``: an id file's path or the ids themselves (required unless the ``.npz`` holds them).
    ``inverse``: the file holds ``T_camera_template``; each transform is inverted.
    """
    import pandas as pd

    from catpose.geometry import invert_T

    path = Path(path)
    if not path.is_file():
        raise DatasetError(f"predictions file {path} does not exist")
    scores = times = file_ids = None
    magic = {".npy": b"\x93NUMPY", ".npz": b"PK"}[path.suffix.lower()]
    with open(path, "rb") as fh:
        head = fh.read(len(magic))
    if head != magic:
        raise InvalidInputError(
            f"{path}: not a NumPy {path.suffix.lower()} file ({'an empty file' if not head else 'no NumPy header'}); "
            "write it with np.save (.npy) or np.savez (.npz)"
        )
    try:
        if path.suffix.lower() == ".npy":
            T = as_transforms(np.load(path, allow_pickle=False), str(path))
        else:
            with np.load(path, allow_pickle=False) as data:
                arr = _first(data, TRANSFORM_KEYS)
                if arr is None:
                    R, t = _first(data, ROTATION_KEYS), _first(data, TRANSLATION_KEYS)
                    if R is None or t is None:
                        raise InvalidInputError(
                            f"{path}: no transforms; name the array one of {', '.join(TRANSFORM_KEYS)} "
                            f"(or R and t), found {', '.join(data.files) or 'nothing'}"
                        )
                    R, t = np.asarray(R), np.asarray(t)
                    if R.ndim != 3 or R.shape[1:] != (3, 3) or t.shape not in ((len(R), 3), (len(R), 3, 1)):
                        raise InvalidInputError(
                            f"{path}: rotations {R.shape} and translations {t.shape} must be (B, 3, 3) and (B, 3)"
                        )
                    arr = np.concatenate([_real(R, str(path), "R"), _real(t, str(path), "t").reshape(len(R), 3, 1)], 2)
                T = as_transforms(arr, str(path))
                file_ids = _first(data, ID_KEYS)
                scores, times = _first(data, ("scores", "score")), _first(data, ("times", "time"))
    except InvalidInputError:
        raise
    except ValueError as e:  # np.load refuses pickles: an object array (a list of arrays, None, dicts)
        why = str(e).splitlines()[0] if str(e) else type(e).__name__
        if "allow_pickle" in why or "Object arrays" in why:
            raise InvalidInputError(
                f"{path}: holds an object array (pickled Python objects), which is not read; save numeric arrays "
                "with np.save / np.savez (e.g. np.stack the transforms into one (B, 3, 4) array)"
            ) from None
        raise InvalidInputError(
            f"{path}: not a readable NumPy array file ({why}); write it with np.save / np.savez"
        ) from None
    except (OSError, EOFError, zipfile.BadZipFile) as e:  # not a NumPy file, or cut off
        why = str(e).splitlines()[0] if str(e) else type(e).__name__
        raise InvalidInputError(
            f"{path}: not a readable NumPy array file ({why}); write it with np.save / np.savez (a cut-off file: "
            "write it again)"
        ) from None
    if file_ids is not None:
        id_list = [
            i.decode("utf-8", "replace") if isinstance(i, bytes) else str(i) for i in np.asarray(file_ids).reshape(-1)
        ]
    elif ids is None:
        raise InvalidInputError(
            f"{path} holds no sample ids: pass --ids FILE (one sample id per line, in the "
            "arrays' order) or save an 'ids' array in the .npz"
        )
    elif isinstance(ids, (str, Path)):
        id_list = read_ids(ids)
    else:
        id_list = [str(i) for i in ids]
    if len(id_list) != len(T):
        raise InvalidInputError(f"{path}: {len(T)} transforms but {len(id_list)} sample ids; give one id per transform")
    if inverse:
        T = np.stack([invert_T(x) for x in T])
    from catpose.bench.interop.prediction_checks import check_ids, check_pose

    for k, (sid, T_k) in enumerate(zip(id_list, T)):  # only poses are scored, each with an id (issue 23)
        check_ids({"sample_id": sid}, "sample", f"{path}: transform {k}")
        check_pose(T_k, f"{path}: transform {k} ({sid})")

    def per_sample(values, name: str) -> list[float]:
        if values is None:
            return [float("nan")] * len(T)
        v = _real(values, str(path), name).reshape(-1)
        if len(v) != len(T):
            raise InvalidInputError(
                f"{path}: {name} has {len(v)} values for {len(T)} transforms; give one per transform"
            )
        return v.tolist()

    df = pd.DataFrame(
        {"sample_id": id_list, "T": list(T), "score": per_sample(scores, "scores"), "time": per_sample(times, "times")}
    )
    df.attrs["kind"] = "sample"
    return df
