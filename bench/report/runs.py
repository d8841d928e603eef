"""Run directories as a table sees them: their config, their per-sample rows (errors recomputed
from the stored estimates), and the units their protocol scores. Tables, reports and plots read
runs through this module only, from files, never from memory.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from catpose.errors import ConfigError, DatasetError


@dataclass
class Run:
    """One run directory read from disk.

    Attributes:
        path: the run directory.
        config: the resolved config (``config.yaml``) as a plain dict ({} when absent).
        info: ``run.json`` as a dict ({} when absent).
        samples: per-sample rows (pandas DataFrame with the ``samples.jsonl`` columns).
        incomplete: why the run is not a finished run (killed, or still running), None when it is
            (:func:`catpose.bench.run.run_meta.incomplete_reason`); tables, reports and exports say it.
    """

    path: Path
    config: dict
    info: dict
    samples: Any
    incomplete: str | None = None

    def _group_name(self, group: str) -> str | None:
        """The name of config group ``group`` (``method``, ``protocol``) in ``config.yaml``, if any."""
        g = self.config.get(group)
        if isinstance(g, dict) and g.get("name"):
            return str(g["name"])
        return g if isinstance(g, str) else None

    @property
    def method(self) -> str:
        name = self._group_name("method")
        if name:
            return name
        if self.info.get("method"):
            return str(self.info["method"])
        if len(self.samples) and "method" in self.samples:
            return str(self.samples["method"].iloc[0])
        return self.path.name

    @property
    def protocol(self) -> str:
        return self._group_name("protocol") or str(self.info.get("protocol", "gt_model"))

    @property
    def method_config(self) -> dict:
        m = self.config.get("method")
        return m if isinstance(m, dict) else {}


def load_run(path: str | Path) -> Run:
    """Read a run directory (``samples.jsonl`` required, ``config.yaml`` and ``run.json`` optional).

    Rows are read by the runner's reader (:func:`catpose.bench.run.rundir.latest_rows`: a cut-off
    last line of a killed run is skipped with a warning, a retried sample's last row counts), and
    their errors recomputed from the stored poses by the runner's
    :func:`~catpose.bench.run.evaluate.recompute_row_errors` (symmetries included), so tables follow
    the current metric definitions rather than the numbers stored at run time. An unreadable
    ``config.yaml`` or ``run.json``, a damaged ``samples.jsonl`` line, or a ``samples.jsonl``
    without any row raises :class:`DatasetError` naming the run (:mod:`catpose.bench.run.run_meta`).
    """
    import pandas as pd

    from catpose.bench.run.evaluate import recompute_row_errors
    from catpose.bench.run.run_meta import incomplete_reason, read_config, read_run_json
    from catpose.bench.run.rundir import latest_rows

    path = Path(path)
    samples_path = path / "samples.jsonl"
    if not samples_path.is_file():
        what = "is a folder, not a file" if samples_path.is_dir() else "is missing"
        raise DatasetError(
            f"{path} is not a run directory: {samples_path.name} {what}; pass a folder written by `bench run`"
        )
    config = read_config(path)
    info = read_run_json(path)
    samples = pd.DataFrame(latest_rows(samples_path))
    if len(samples) == 0:
        raise DatasetError(
            f"run {path} has no sample rows ({samples_path.name} is empty: its `bench run` finished no sample); "
            "re-run it, or leave it out"
        )
    named = (config.get("method") or {}).get("name") if isinstance(config.get("method"), dict) else None
    in_rows = sorted({str(m) for m in samples.get("method", [])} - {str(named)})
    if named and in_rows:
        raise DatasetError(
            f"run {path}: config.yaml names method {named!r} but its rows are of {in_rows[0]!r}; restore config.yaml "
            "(it labels the run in tables)"
        )
    if {"T_est", "T_gt", "status"} <= set(samples.columns):  # else rows without poses: their errors as written
        samples = pd.DataFrame([recompute_row_errors(r) for r in samples.to_dict("records")], index=samples.index)
    return Run(
        path=path,
        config=config,
        info=info,
        samples=samples,
        incomplete=incomplete_reason(path, info, len(samples)),
    )


def load_runs(paths: Sequence[str | Path]) -> tuple[list[Run], list[str]]:
    """Every run directory given or found below ``paths`` (:func:`find_run_dirs`), read with
    :func:`load_run`; a run that cannot be read is left out and its one-line reason
    returned, so one damaged run does not stop the others: ``(runs, reasons)``."""
    from catpose.errors import CatposeError

    reasons: list[str] = []
    runs = []
    for d in find_run_dirs(paths):
        try:
            runs.append(load_run(d))
        except CatposeError as e:
            reasons.append(str(e))
    return runs, reasons


def print_left_out(command: str, runs: Sequence[Run], reasons: Sequence[str]) -> None:
    """Each run left out by :func:`load_runs`, one ``bench <command>: error: left out: ...`` line each
    (stderr); the command then exits with status 2 after doing what it can with the others. With
    no run left at all it raises instead (one line when one run was given). Then one ``bench
    <command>: warning: run ... is incomplete`` line per incomplete run (:attr:`Run.incomplete`;
    tables and reports note them too)."""
    import sys

    from catpose.errors import command_error

    if not runs and len(reasons) == 1:
        raise DatasetError(reasons[0])
    for why in reasons:
        print(command_error(command, f"left out: {why}"), file=sys.stderr)
    if not runs:
        raise DatasetError(f"no run could be read ({len(reasons)} left out, see above)")
    for run in runs:
        if run.incomplete:
            print(f"bench {command}: warning: {run.incomplete}", file=sys.stderr)


def find_run_dirs(paths: Sequence[str | Path]) -> list[Path]:
    """Run directories given directly or found below the given folders (sorted, no duplicates)."""
    from catpose.bench.run.overwrite import absolute_path, runs_below

    out: list[Path] = []
    for p in map(Path, paths):
        if not p.is_dir():
            absolute_path(p)  # a loop of symbolic links: said as such
            raise DatasetError(
                f"{p} {'is a file' if p.exists() else 'does not exist'}; pass run directories written by `bench run`"
            )
        found = runs_below([p])
        if not found:
            raise DatasetError(f"no samples.jsonl below {p}; pass run directories written by `bench run`")
        out.extend(found)
    seen: set[Path] = set()
    return [p for p in out if not (p.resolve() in seen or seen.add(p.resolve()))]


def protocol_of(run: Run):
    """The run's protocol, built from its ``config.yaml`` as the runner builds it; runs without a
    protocol config (external predictions written by hand) get the built-in protocol of their
    name."""
    cfg = run.config.get("protocol") if isinstance(run.config.get("protocol"), dict) else None
    if cfg and cfg.get("_target_"):
        from catpose.bench.run.build import build_protocol

        return build_protocol(run.config)
    from catpose.bench.protocols.absolute import GtModel, Templates

    if run.protocol == "relative":
        from catpose.bench.protocols.relative import Relative

        return Relative(choice="score")  # rows written elsewhere carry no cross facts: only their scores can choose
    return Templates(choice="score") if run.protocol == "templates" else GtModel()


def scored_units(run: Run, error: str = "err_deg"):
    """The run's scoring units (protocol ``score_units``); ``error="oracle_err_deg"`` uses the
    templates protocol's minimum error across templates as ``err_deg`` (an oracle), and that
    registration's translation error as ``trans_err``."""
    units = protocol_of(run).score_units(run.samples)
    if error != "err_deg":
        if error not in units:
            raise ConfigError(
                f"run {run.path} has no column {error!r}; the oracle exists only for the templates protocol"
            )
        units = units.assign(err_deg=units[error])
        if error == "oracle_err_deg" and "oracle_trans_err" in units:  # the oracle's own registration
            units = units.assign(trans_err=units["oracle_trans_err"])
    return units
