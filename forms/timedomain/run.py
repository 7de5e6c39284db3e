"""A time-domain run of the sliding strip: set-up, stepping loop, files written as it goes.

The driver of the time-domain scene (``workflows/time_domain.py``, docs/time_domain.md) on top
of the stepper :mod:`forms.timedomain.model`:

- :func:`setup_strip`: the periodic strip (whole wavelengths), the stepper, the semi-discrete
  eigenmode near the exact eigenvalue and the initial condition (steady sliding plus that mode,
  or the cross-section model's mode).
- :class:`RunWriter`: the run's files in one folder, written as the run goes:
  ``timeseries.csv`` (one row per step, :data:`CSV_COLUMNS`), ``interface_NNNN.npz``
  (interface frames in chunks), ``checkpoint_rank*.npz`` and ``checkpoint.json`` (resume), and
  optionally ``fields.xdmf`` (displacement perturbation). :func:`read_checkpoint`,
  :func:`read_outputs` read them back.
- :func:`run_time_domain`: the stepping loop: one time-series row per step, a frame every
  ``frame_every`` steps, the friction theta switched when the linear window ends, a stop at
  the end of the model's validity (:func:`end_of_validity`: opening or slip-rate reversal).
- :func:`run_record`: the run's ``summary.json`` record.

Collective where the stepper is (every rank calls everything); files are written by rank 0,
except each rank's own checkpoint.
"""

from __future__ import annotations

import csv
import glob
import json
import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from analytic.cli import dumps
from forms.timedomain.model import Mode, NonlinearLaw, Sample, TimeDomainStrip, build_time_domain

#: Columns of ``timeseries.csv``.
CSV_COLUMNS = ["step", "t", "re_c", "im_c", "energy", "energy_change", "work_friction",
               "min_sigma", "min_v", "max_dv", "newton", "top_force"]
#: Interface fields of a frame (besides its time ``t`` and the positions ``x``).
FRAME_FIELDS = ("v", "tau", "sigma", "theta")


def setup_strip(comm: object, law: NonlinearLaw, k: float, exact: complex, *, wavelengths: int,
                cells_per_wavelength: int, ny: int, cell: str, cfl: float, dt: float | None,
                initial: str, amplitude: float) -> tuple[TimeDomainStrip, Mode]:
    """Build the strip and the stepper, and set the initial condition (collective).

    Args:
        comm: Communicator of the mesh.
        law: Friction law (holds the linear parameters; ``H`` is the strip's height).
        k: Wavenumber of the excited mode.
        exact: Its exact eigenvalue (target of the semi-discrete eigenvalue solve).
        wavelengths: Strip length in wavelengths ``2 pi / k``.
        cells_per_wavelength: Cells along ``x`` per wavelength.
        ny: Cells along ``y``.
        cell: ``"quadrilateral"`` (Q1) or ``"triangle"`` (P1).
        cfl: Time step as a fraction of the stable step.
        dt: Explicit time step (overrides ``cfl``), or ``None``.
        initial: ``"lumped"`` (the linearised lumped system's eigenvector) or
            ``"cross-section"`` (the 1D model's mode interpolated on the strip).
        amplitude: Initial ``max |v/v0 - 1|`` along the interface.

    Returns:
        The stepper (destroy it when done) and the semi-discrete mode (its eigenvalue is
        reported in any case).
    """
    from meshes.strip import strip_mesh

    length = wavelengths * 2.0 * math.pi / k
    strip = strip_mesh(comm, length, law.params.H, wavelengths * cells_per_wavelength, ny,
                       cell=cell)
    td = build_time_domain(strip, law, k, cfl=cfl, dt=dt)
    mode = td.linear_mode(exact)
    if initial == "cross-section":
        td.set_initial_mode(td.cross_section_mode(exact), amplitude)
    else:
        td.set_initial_mode(mode, amplitude)
    return td, mode


def read_checkpoint(folder: str) -> dict | None:
    """The record ``checkpoint.json`` of a run in ``folder`` (``None`` if there is none)."""
    path = os.path.join(folder, "checkpoint.json")
    if not os.path.exists(path):
        return None
    with open(path) as fh:
        return json.load(fh)


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
        self._xdmf = None

    @property
    def _rank0(self) -> bool:
        return self.comm.rank == 0

    def _path(self, name: str) -> str:
        return os.path.join(self.folder, name)

    def start(self, td: TimeDomainStrip, resume: dict | None = None) -> float | None:
        """Prepare the files; with a checkpoint record, restore ``td`` from it (collective).

        A fresh run removes old interface chunks and writes the CSV header; a resumed one
        loads this rank's state, drops the rows and chunks written after the checkpoint.

        Returns:
            The time at which the friction theta was switched (``None``: not yet).
        """
        if self._rank0:
            os.makedirs(self.folder, exist_ok=True)
        self.comm.barrier()
        ts_path = self._path("timeseries.csv")
        theta_switch = None
        if resume is not None:
            with np.load(self._path(f"checkpoint_rank{self.comm.rank}.npz")) as z:
                td.load_state(dict(z))
            self.chunk_index = int(resume["chunk"])
            td.friction_theta = float(resume.get("friction_theta", 0.5))
            theta_switch = resume.get("theta_switch")
            if self._rank0:  # drop rows written after the checkpoint
                with open(ts_path) as fh:
                    rows = list(csv.reader(fh))
                keep = [rows[0]] + [r for r in rows[1:] if int(r[0]) < td.step]
                with open(ts_path, "w", newline="") as fh:
                    csv.writer(fh).writerows(keep)
                self._remove_chunks(self.chunk_index)
        elif self._rank0:
            self._remove_chunks(0)
            with open(ts_path, "w", newline="") as fh:
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
                np.savez_compressed(self._path(f"interface_{self.chunk_index:04d}.npz"),
                                    x=self.x_interface, **{kk: np.array(vv) for kk, vv in
                                                           self.frames.items()})
        if self.pending:
            self.chunk_index += 1
        self.pending = 0
        self.rows.clear()
        for vv in self.frames.values():
            vv.clear()
        np.savez(self._path(f"checkpoint_rank{self.comm.rank}.npz"), **td.state_arrays())
        self.comm.barrier()
        if self._rank0:
            with open(self._path("checkpoint.json"), "w") as fh:
                fh.write(dumps({"config": self.config, "step": td.step,  # strict JSON
                                "chunk": self.chunk_index, "friction_theta": td.friction_theta,
                                "theta_switch": theta_switch}))


def end_of_validity(s: Sample, fields: dict[str, np.ndarray]) -> dict[str, object]:
    """Why an invalid step ends the run, when, and where along the interface.

    Args:
        s: The sample of the step (``min_sigma <= 0``: opening; else ``min_v < 0``).
        fields: Its interface fields (rank 0's :meth:`TimeDomainStrip.interface_fields`).
    """
    opening = s.min_sigma <= 0
    bad = fields["sigma"] <= -1.0 if opening else fields["v"] < 0
    return {"reason": "opening (normal stress reached zero)" if opening
            else "slip rate reversed", "t": s.t, "x": [float(v) for v in fields["x"][bad]]}


@dataclass
class RunOutcome:
    """What :func:`run_time_domain` did.

    Attributes:
        stop: ``reason`` (``"t_end"`` or :func:`end_of_validity`'s), ``t``, ``x`` (every rank).
        theta_switch: Time at which the friction theta was switched (``None``: never).
        steps_run: Steps taken by this call.
        run_time: Wall time of the loop (s).
    """

    stop: dict = field(default_factory=dict)
    theta_switch: float | None = None
    steps_run: int = 0
    run_time: float = 0.0


def run_time_domain(td: TimeDomainStrip, writer: RunWriter, n_steps: int, frame_every: int,
                    linear_limit: float, friction_theta: float,
                    theta_switch: float | None = None,
                    progress: Callable[[int], object] | None = None) -> RunOutcome:
    """Step ``td`` up to step ``n_steps`` or the first invalid step, writing as it goes.

    Every step: a time-series row. When ``max |v/v0 - 1|`` first exceeds ``linear_limit``
    the friction force is taken at ``friction_theta`` from then on (1/2 before). Every
    ``frame_every`` steps and at an invalid step (normal stress reaching zero, slip rate
    reversing): an interface frame; the writer flushes every ``writer.chunk`` frames and at
    the end. Collective.

    Args:
        td: The stepper, with its initial condition (or restored state).
        writer: The run's files (:meth:`RunWriter.start` called).
        n_steps: Last step.
        frame_every: Steps between interface frames.
        linear_limit: End of the linear window in ``max |v/v0 - 1|``.
        friction_theta: The friction theta after the linear window.
        theta_switch: Time of an earlier switch (a resumed run), or ``None``.
        progress: Called with 50 every 50 steps (a progress bar), or ``None``.
    """
    out = RunOutcome(stop={"reason": "t_end", "t": None, "x": None}, theta_switch=theta_switch)
    t_run = time.perf_counter()
    while td.step < n_steps:
        td.advance()
        out.steps_run += 1
        s = td.sample()
        writer.add_sample(s)
        invalid = s.min_sigma <= 0.0 or s.min_v < 0.0
        if s.max_dv > linear_limit and td.friction_theta != friction_theta:
            td.friction_theta = friction_theta  # the linear window is over
            out.theta_switch = s.t
        if s.step % frame_every == 0 or invalid:
            fields = td.interface_fields()
            writer.add_frame(s.t, fields)
            if invalid and td.comm.rank == 0:
                out.stop = end_of_validity(s, fields)
            if writer.pending >= writer.chunk and not invalid:
                writer.flush(td, out.theta_switch)
        writer.add_fields(td, s.step, s.t, force=invalid)
        if progress is not None and td.step % 50 == 0:
            progress(50)
        if invalid:
            break
    out.run_time = time.perf_counter() - t_run
    writer.close_fields()
    writer.flush(td, out.theta_switch)
    out.stop = td.comm.bcast(out.stop, root=0)
    return out


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


def run_record(td: TimeDomainStrip, mode: Mode, label: str, exact: complex,
               analysis: dict[str, object], outcome: RunOutcome, *, nx: int, ny: int, cell: str,
               friction_theta: float, t_end: float, inputs: dict[str, object],
               setup_time: float, command: str, versions: dict) -> dict[str, object]:
    """The ``summary.json`` record of a run (rank 0; no collective call).

    Args:
        td: The stepper after the run.
        mode: Its semi-discrete mode (:func:`setup_strip`).
        label: Branch label excited.
        exact: Its exact eigenvalue.
        analysis: :func:`analytic.studies.growth_fit.summarise_run` of the recorded run.
        outcome: :func:`run_time_domain`'s outcome.
        nx: Cells along ``x`` (whole strip).
        ny: Cells along ``y``.
        cell: Cell type.
        friction_theta: The friction theta after the linear window.
        t_end: Requested run length.
        inputs: Run inputs beyond the parameters and the law (amplitude, linear limit).
        setup_time: Wall time of the set-up (s).
        command: The command line.
        versions: Library versions.
    """
    law = td.law
    run_time, steps_run = outcome.run_time, outcome.steps_run
    return {
        "command": command,
        "branch": label, "k": td.k,
        "predicted": {"re_lambda": exact.real, "im_lambda": exact.imag, "source":
                      "analytic.follow_branch (exact root of det M)"},
        "measured": analysis["measured"],
        "relative_difference": analysis["relative_difference"],
        "semi_discrete": {"re_lambda": mode.eigenvalue.real, "im_lambda": mode.eigenvalue.imag,
                          "residual": mode.residual,
                          "note": "eigenvalue of the linearised lumped Q1/P1 system on this"
                                  " mesh (time continuous): measured - this is the time-step"
                                  " error, this - predicted the spatial error"},
        "window": analysis["window"],
        "mesh": {"cell": cell, "nx": nx, "ny": ny, "length": td.strip.length,
                 "height": law.params.H, "unknowns": td.num_dofs},
        "dt": td.dt, "dt_stable": td.dt_stable,
        "friction_theta": {"linear_window": 0.5, "after": friction_theta,
                           "switched_at_t": outcome.theta_switch},
        "steps": analysis["steps"],
        "t_end_requested": t_end,
        "parameters": {**law.params.as_dict(), **law.summary(), **inputs},
        "end": outcome.stop,
        "energy_balance": analysis["energy_balance"],
        "nonlinear": analysis["nonlinear"],
        "timing": {"setup_s": setup_time, "run_s": run_time, "steps_run": steps_run,
                   "steps_per_s": steps_run / run_time if run_time > 0 else None,
                   "ranks": td.comm.size},
        "versions": versions,
    }
