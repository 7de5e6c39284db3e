"""The time-domain scene's files: written as the run goes, checkpointed as parts, read back.

:class:`RunWriter` is the :class:`forms.timedomain.run.Recorder` of ``workflows/time_domain.py``:
in one folder, ``timeseries.csv`` (one row per step, :data:`CSV_COLUMNS`), ``interface_NNNN.npz``
(interface frames in chunks), the checkpoint as parts (:mod:`_parts`, the one resume mechanism:
``checkpoint_rank<r>.npz`` each rank's :meth:`TimeDomainStrip.state_arrays`, then
``checkpoint.json`` rank 0's record) and optionally ``fields.xdmf`` (displacement perturbation).
:func:`read_checkpoint` and :func:`read_outputs` read them back.

Files are written by rank 0, except each rank's own checkpoint part.
"""

from __future__ import annotations

import csv
import glob
import os

import numpy as np
from _parts import Parts
from _writing import atomic_open

from forms.timedomain.model import Sample, TimeDomainStrip

#: Columns of ``timeseries.csv``.
CSV_COLUMNS = ["step", "t", "re_c", "im_c", "energy", "energy_change", "work_friction",
               "min_sigma", "min_v", "max_dv", "newton", "top_force"]
#: Interface fields of a frame (besides its time ``t`` and the positions ``x``).
FRAME_FIELDS = ("v", "tau", "sigma", "theta")
#: Name of the checkpoint's record part (rank 0); each rank's state is ``checkpoint_rank<r>``.
CHECKPOINT = "checkpoint"


def checkpoint_parts(folder: str) -> Parts:
    """The checkpoint parts of a run in ``folder``."""
    return Parts(folder, CHECKPOINT + "*")


def read_checkpoint(folder: str) -> dict | None:
    """The record ``checkpoint.json`` of a run in ``folder`` (``None`` if there is none)."""
    return checkpoint_parts(folder).load(CHECKPOINT)


class RunWriter:
    """The files of one run in ``folder``, written as it goes (every rank holds one).

    Rows and frames are kept in memory (rank 0) and written by :meth:`flush`, with a
    checkpoint, every ``chunk`` frames; each flush of frames writes one ``interface_NNNN.npz``.

    Args:
        comm: Communicator of the run.
        folder: Output folder (created if missing).
        config: Options that a resumed run must match (stored in ``checkpoint.json``).
        chunk: Frames per ``interface_NNNN.npz``.
        xdmf_every: Write the displacement perturbation to ``fields.xdmf`` every this many
            steps (0: never).
    """

    def __init__(self, comm: object, folder: str, config: dict, chunk: int,
                 xdmf_every: int = 0) -> None:
        self.comm = comm
        self.folder = folder
        self.config = config
        self.chunk = chunk
        self.xdmf_every = xdmf_every
        self.chunk_index = 0
        self.pending = 0  #: frames gathered since the last flush (every rank counts)
        self.rows: list[list] = []
        self.frames: dict[str, list] = {"t": [], **{key: [] for key in FRAME_FIELDS}}
        self.x_interface: np.ndarray | None = None
        self.parts = checkpoint_parts(folder)
        self._xdmf = None

    @property
    def _rank0(self) -> bool:
        return self.comm.rank == 0

    def _path(self, name: str) -> str:
        return os.path.join(self.folder, name)

    def start(self, td: TimeDomainStrip, resume: dict | None = None) -> float | None:
        """Prepare the files; with a checkpoint record, restore ``td`` from it (collective).

        A fresh run removes old interface chunks and checkpoint parts and writes the CSV
        header; a resumed one loads this rank's state, drops the rows and chunks written after
        the checkpoint.

        Returns:
            The time at which the friction theta was switched (``None``: not yet).
        """
        if self._rank0:
            os.makedirs(self.folder, exist_ok=True)
        self.comm.barrier()
        ts_path = self._path("timeseries.csv")
        theta_switch = None
        if resume is not None:
            td.load_state(self.parts.load(f"{CHECKPOINT}_rank{self.comm.rank}"))
            self.chunk_index = int(resume["chunk"])
            td.friction_theta = float(resume.get("friction_theta", 0.5))
            theta_switch = resume.get("theta_switch")
            if self._rank0:  # drop rows written after the checkpoint
                with open(ts_path) as fh:
                    rows = list(csv.reader(fh))
                keep = [rows[0]] + [r for r in rows[1:] if int(r[0]) < td.step]
                with atomic_open(ts_path, "w", newline="") as fh:
                    csv.writer(fh).writerows(keep)
                self._remove_chunks(self.chunk_index)
        elif self._rank0:
            self._remove_chunks(0)
            self.parts.clear()
            with atomic_open(ts_path, "w", newline="") as fh:
                csv.writer(fh).writerow(CSV_COLUMNS)
        if self.xdmf_every:
            from dolfinx.io import XDMFFile

            # appended on resume would need XDMF surgery: a resumed run starts a new file
            self._xdmf = XDMFFile(self.comm, self._path("fields.xdmf"), "w")
            self._xdmf.write_mesh(td.strip.mesh)
        return theta_switch

    def _remove_chunks(self, first: int) -> None:
        for path in glob.glob(self._path("interface_*.npz")):
            if int(os.path.basename(path)[10:14]) >= first:
                os.remove(path)

    def add_sample(self, s: Sample) -> None:
        """One time-series row (full precision)."""
        self.rows.append([s.step, repr(s.t), repr(s.coefficient.real),
                          repr(s.coefficient.imag), repr(s.energy), repr(s.energy_change),
                          repr(s.work_friction), repr(s.min_sigma), repr(s.min_v),
                          repr(s.max_dv), s.newton_max, repr(s.top_force)])

    def add_frame(self, t: float, fields: dict[str, np.ndarray] | None) -> None:
        """One interface frame (``fields`` of :meth:`TimeDomainStrip.interface_fields`)."""
        self.pending += 1
        if self._rank0:
            self.x_interface = fields["x"]
            self.frames["t"].append(t)
            for key in FRAME_FIELDS:
                self.frames[key].append(fields[key])

    def add_fields(self, td: TimeDomainStrip, step: int, t: float, force: bool = False) -> None:
        """The displacement perturbation into ``fields.xdmf`` every ``xdmf_every`` steps."""
        if self._xdmf is not None and (step % self.xdmf_every == 0 or force):
            self._xdmf.write_function(td.displacement(), t)

    def close_fields(self) -> None:
        """Close ``fields.xdmf`` (collective)."""
        if self._xdmf is not None:
            self._xdmf.close()
            self._xdmf = None

    def flush(self, td: TimeDomainStrip, theta_switch: float | None) -> None:
        """Write the rows and frames held, and a checkpoint (collective)."""
        if self._rank0:
            with open(self._path("timeseries.csv"), "a", newline="") as fh:
                csv.writer(fh).writerows(self.rows)
            if self.frames["t"]:
                with atomic_open(self._path(f"interface_{self.chunk_index:04d}.npz"),
                                 "wb") as fh:
                    np.savez_compressed(fh, x=self.x_interface,
                                        **{kk: np.array(vv) for kk, vv in self.frames.items()})
        if self.pending:
            self.chunk_index += 1
        self.pending = 0
        self.rows.clear()
        for vv in self.frames.values():
            vv.clear()
        self.parts.save(f"{CHECKPOINT}_rank{self.comm.rank}", td.state_arrays())
        self.comm.barrier()
        if self._rank0:
            self.parts.save(CHECKPOINT, {"config": self.config, "step": td.step,
                                         "chunk": self.chunk_index,
                                         "friction_theta": td.friction_theta,
                                         "theta_switch": theta_switch})


def read_outputs(folder: str) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The time series (structured array) and the concatenated interface frames of a run.

    The frames dict has ``x`` (``None`` without chunks) and, if any chunk exists, ``t`` and
    the :data:`FRAME_FIELDS`.
    """
    data = np.genfromtxt(os.path.join(folder, "timeseries.csv"), delimiter=",", names=True)
    data = np.atleast_1d(data)
    chunks = sorted(glob.glob(os.path.join(folder, "interface_*.npz")))
    frames: dict[str, list] = {}
    x = None
    for path in chunks:
        with np.load(path) as z:
            x = z["x"]
            for key in ("t", *FRAME_FIELDS):
                frames.setdefault(key, []).append(z[key])
    merged = {key: np.concatenate(v) for key, v in frames.items()}
    merged["x"] = x
    return data, merged
