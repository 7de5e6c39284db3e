"""A time-domain run of the sliding strip: set-up and stepping loop (no files).

The driver of the time-domain scene (``workflows/time_domain.py``, docs/time_domain.md) on top
of the stepper :mod:`forms.timedomain.model`:

- :func:`setup_strip`: the periodic strip of the one 2D model (whole wavelengths), the
  stepper, the semi-discrete eigenmode near the exact eigenvalue and the initial condition
  (steady sliding plus that mode, or the cross-section model's mode).
- :func:`run_time_domain`: the stepping loop: one time-series row per step, a frame every
  ``frame_every`` steps, the friction theta switched when the linear window ends, a stop at
  the end of the model's validity (:func:`end_of_validity`: opening or slip-rate reversal).
  What is recorded goes to a :class:`Recorder` given by the caller (the scene's files:
  ``workflows/_time_files.py``; the checkpoint is :meth:`TimeDomainStrip.state_arrays`).
- :func:`run_record`: the run's ``summary.json`` record (a dict).

Collective where the stepper is (every rank calls everything).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from forms.models.strip import strip_mesh_for
from forms.timedomain.model import Mode, NonlinearLaw, Sample, TimeDomainStrip, build_time_domain


class Recorder(Protocol):
    """Where :func:`run_time_domain` puts what it records (every rank holds one).

    Attributes:
        chunk: Frames held before :meth:`flush` is due.
        pending: Frames added since the last :meth:`flush` (every rank counts).
    """

    chunk: int
    pending: int

    def add_sample(self, s: Sample) -> None:
        """One time-series row."""

    def add_frame(self, t: float, fields: dict[str, np.ndarray] | None) -> None:
        """One interface frame (rank 0's :meth:`TimeDomainStrip.interface_fields`)."""

    def add_fields(self, td: TimeDomainStrip, step: int, t: float, force: bool = False) -> None:
        """The displacement field of a step, if the recorder keeps fields."""

    def close_fields(self) -> None:
        """End of the fields (collective)."""

    def flush(self, td: TimeDomainStrip, theta_switch: float | None) -> None:
        """Keep what is held and a checkpoint of ``td`` (collective)."""


def setup_strip(comm: object, law: NonlinearLaw, k: float, exact: complex, *, wavelengths: int,
                cells_per_wavelength: int, ny: int, cell: str, cfl: float, dt: float | None,
                initial: str, amplitude: float) -> tuple[TimeDomainStrip, Mode]:
    """Build the strip and the stepper, and set the initial condition (collective).

    Args:
        comm: Communicator of the mesh.
        law: Friction law (holds the linear parameters; ``H`` is the strip's height, with
            two bodies ``H2`` the substrate's depth).
        k: Wavenumber of the excited mode.
        exact: Its exact eigenvalue (target of the semi-discrete eigenvalue solve).
        wavelengths: Strip length in wavelengths ``2 pi / k``.
        cells_per_wavelength: Cells along ``x`` per wavelength.
        ny: Cells along ``y`` (in each body: the substrate has as many).
        cell: ``"quadrilateral"`` (Q1) or ``"triangle"`` (P1; two bodies: triangles only).
        cfl: Time step as a fraction of the stable step.
        dt: Explicit time step (overrides ``cfl``), or ``None``.
        initial: ``"lumped"`` (the linearised lumped system's eigenvector) or
            ``"cross-section"`` (the 1D model's mode interpolated on the strip).
        amplitude: Initial ``max |v/v0 - 1|`` along the interface.

    Returns:
        The stepper (destroy it when done) and the semi-discrete mode (its eigenvalue is
        reported in any case).
    """
    length = wavelengths * 2.0 * math.pi / k
    strip = strip_mesh_for(comm, law.params, length, wavelengths * cells_per_wavelength, ny,
                           cell=cell)
    td = build_time_domain(strip, law, k, cfl=cfl, dt=dt)
    mode = td.linear_mode(exact)
    if initial == "cross-section":
        td.set_initial_mode(td.cross_section_mode(exact), amplitude)
    else:
        td.set_initial_mode(mode, amplitude)
    return td, mode


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


#: Seconds per time step: fixed, and per unknown. Measured on this 2-core machine, one rank:
#: workflows/results/time_domain/benchmark.csv, 1478 steps at 2176, 8448, 33 280 unknowns in
#: 0.92, 1.78, 7.09 s (model 1.96, 3.35, 8.87 s; the stepping only), and the README run
#: (summary.json timing: 7762 steps at 2176 unknowns, 14.5 s with its files; model 10.3 s).
#: Two ranks were slower there (benchmark.csv: 17.4, 13.0, 75.4 s): no speed-up assumed.
STEP_SECONDS = (1.0e-3, 1.5e-7)


def estimate_seconds(unknowns: int, steps: int) -> float:
    """Estimated seconds of ``steps`` time steps of a mesh with ``unknowns`` unknowns."""
    return steps * (STEP_SECONDS[0] + STEP_SECONDS[1] * unknowns)


def run_time_domain(td: TimeDomainStrip, writer: Recorder, n_steps: int, frame_every: int,
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
        writer: Where the records go (the scene's files, started).
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
                      "analytic.follow_branch (exact root of det M; two bodies: of"
                      " analytic.physics.twobody.det_twobody)"},
        "measured": analysis["measured"],
        "relative_difference": analysis["relative_difference"],
        "semi_discrete": {"re_lambda": mode.eigenvalue.real, "im_lambda": mode.eigenvalue.imag,
                          "residual": mode.residual,
                          "note": "eigenvalue of the linearised lumped Q1/P1 system on this"
                                  " mesh (time continuous): measured - this is the time-step"
                                  " error, this - predicted the spatial error"},
        "window": analysis["window"],
        "mesh": {"cell": cell, "nx": nx, "ny": ny, "length": td.strip.length,
                 "height": law.params.H, "unknowns": td.num_dofs,
                 "substrate_depth": law.params.H2 if td.two_body else 0.0},
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
