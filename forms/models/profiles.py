"""Material input of the 1D model: depth profiles ``mu(y), rho(y), beta(y)`` and layer files.

docs/design.md section 5, "Layers and profiles". Two ways to describe a slider whose material
varies with the height ``y`` above the interface (units of the first layer, ``y = 0`` the
interface):

- a **layers file** (:func:`read_layers`): CSV with the columns ``y_top,mu,rho,beta``, one row
  per layer from the interface upwards; the last ``y_top`` is the slider height ``H``;
- a **profile** (:class:`Profile`): a Python expression of ``y`` such as
  ``"1 - 0.6*exp(-y/0.05)"``, made only of numbers, ``y``, ``pi``, ``+ - * / **`` and the
  functions of :data:`FUNCTIONS`. It is evaluated with numpy (checks, plots) and as a UFL
  expression of the spatial coordinate (exact at every quadrature point of the forms).

Nothing here writes files; a bad input raises :class:`analytic.params.ParameterError` with one
line naming it and what is allowed.
"""

from __future__ import annotations

import ast
import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import ufl

from analytic.params import ParameterError, Params

#: Functions a profile may call: name -> (numpy function, UFL function).
FUNCTIONS = {
    "exp": (np.exp, ufl.exp), "log": (np.log, ufl.ln), "sqrt": (np.sqrt, ufl.sqrt),
    "sin": (np.sin, ufl.sin), "cos": (np.cos, ufl.cos), "tan": (np.tan, ufl.tan),
    "sinh": (np.sinh, ufl.sinh), "cosh": (np.cosh, ufl.cosh), "tanh": (np.tanh, ufl.tanh),
    "arctan": (np.arctan, ufl.atan), "abs": (np.abs, abs),
    "minimum": (np.minimum, ufl.min_value), "maximum": (np.maximum, ufl.max_value),
}
#: Named constants a profile may use.
CONSTANTS = {"pi": math.pi}
_NODES = (ast.Expression, ast.BinOp, ast.UnaryOp, ast.Call, ast.Name, ast.Load, ast.Constant,
          ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow, ast.USub, ast.UAdd)
#: Columns of a layers file.
LAYER_COLUMNS = ("y_top", "mu", "rho", "beta")
#: Each material coefficient lies in ``0 < value < MATERIAL_HIGH[name]`` (a layers file's row,
#: a profile on the slider, :class:`forms.models.section.Layer`).
MATERIAL_HIGH = {"mu": math.inf, "rho": math.inf, "beta": 1 / math.sqrt(2)}


def _check_tree(tree: ast.AST, name: str, text: str) -> None:
    """Raise unless ``tree`` uses only numbers, ``y``, constants and :data:`FUNCTIONS`."""
    allowed = ", ".join(sorted(FUNCTIONS))
    for node in ast.walk(tree):
        bad = None
        if not isinstance(node, _NODES):
            bad = type(node).__name__
        elif isinstance(node, ast.Constant) and not isinstance(node.value, (int, float)):
            bad = repr(node.value)
        elif isinstance(node, ast.Name) and node.id not in {"y", *CONSTANTS, *FUNCTIONS}:
            bad = node.id
        elif isinstance(node, ast.Call) and (node.keywords or not isinstance(node.func, ast.Name)
                                             or node.func.id not in FUNCTIONS):
            bad = "a call"
        if bad is not None:
            raise ParameterError(f"{name} = {text!r}: {bad} is not allowed (an expression of y "
                                 f"with numbers, pi, + - * / ** and {allowed})")


@dataclass(frozen=True)
class Profile:
    """A material coefficient as a function of ``y`` (a checked Python expression).

    Attributes:
        text: The expression, e.g. ``"1 - 0.6*exp(-y/0.05)"``.
        name: What it describes (``"mu"``, ``"rho"``, ``"beta"``), for messages.
    """

    text: str
    name: str = "profile"

    def __post_init__(self) -> None:
        try:
            tree = ast.parse(self.text.strip(), mode="eval")
        except SyntaxError:
            raise ParameterError(f"{self.name} = {self.text!r} is not a Python expression of "
                                 "y") from None
        _check_tree(tree, self.name, self.text)
        object.__setattr__(self, "_code", compile(tree, f"<{self.name}>", "eval"))
        try:
            self(np.array([0.0, 0.5]))
        except (TypeError, ValueError, ArithmeticError) as err:
            raise ParameterError(f"{self.name} = {self.text!r} cannot be evaluated "
                                 f"({type(err).__name__})") from None

    def _eval(self, y: object, table: int) -> object:
        names = {key: fns[table] for key, fns in FUNCTIONS.items()}
        names.update(CONSTANTS, y=y)
        return eval(self._code, {"__builtins__": {}}, names)  # noqa: S307 (checked tree)

    def __call__(self, y: np.ndarray) -> np.ndarray:
        """Values at the points ``y`` (numpy)."""
        y = np.asarray(y, dtype=float)
        with np.errstate(all="ignore"):
            return np.broadcast_to(np.asarray(self._eval(y, 0), dtype=float), y.shape)

    def ufl(self, y: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """The expression in UFL, of the coordinate ``y`` (e.g. ``SpatialCoordinate(mesh)[0]``)."""
        return self._eval(y, 1)

    def check(self, bottom: float, top: float, low: float, high: float = math.inf) -> None:
        """Raise unless ``low < value < high`` on ``[bottom, top]`` (checked at 2001 points)."""
        y = np.linspace(bottom, top, 2001)
        v = self(y)
        bad = ~(np.isfinite(v) & (v > low) & (v < high))
        if np.any(bad):
            i = int(np.argmax(bad))
            bound = (f"{low:g} < {self.name} < {high:.4g}" if math.isfinite(high)
                     else f"{self.name} > {low:g}")
            raise ParameterError(f"{self.name} = {self.text!r} leaves {bound} on {bottom:g} "
                                 f"<= y <= {top:g} (it is {v[i]:.4g} at y = {y[i]:.4g})")


@dataclass(frozen=True)
class LayerRow:
    """One row of a layers file: the layer below ``y_top`` (down to the previous ``y_top``)."""

    y_top: float
    mu: float
    rho: float
    beta: float


def parse_layers(rows: list[dict[str, str]], source: str = "layers") -> list[LayerRow]:
    """Check the rows of a layers table (dicts with :data:`LAYER_COLUMNS`).

    Raises:
        ParameterError: A missing column, a value that is not a number, ``y_top`` not
            increasing from ``> 0``, ``mu <= 0``, ``rho <= 0`` or ``beta`` outside
            ``(0, 1/sqrt(2))``.
    """
    if not rows:
        raise ParameterError(f"{source}: no layer (columns {','.join(LAYER_COLUMNS)})")
    missing = [c for c in LAYER_COLUMNS if c not in rows[0]]
    if missing:
        raise ParameterError(f"{source}: columns {','.join(LAYER_COLUMNS)} needed, "
                             f"{','.join(missing)} missing")
    out, below = [], 0.0
    for i, row in enumerate(rows, start=1):
        try:
            r = LayerRow(*(float(row[c]) for c in LAYER_COLUMNS))
        except (TypeError, ValueError):
            raise ParameterError(f"{source} row {i}: {','.join(LAYER_COLUMNS)} must be "
                                 "numbers") from None
        if not (math.isfinite(r.y_top) and r.y_top > below):
            raise ParameterError(f"{source} row {i}: y_top = {r.y_top} must be finite and "
                                 f"> {below} (increasing from the interface)")
        if not all(0 < getattr(r, name) < high for name, high in MATERIAL_HIGH.items()):
            raise ParameterError(f"{source} row {i}: mu > 0, rho > 0 and 0 < beta < 0.7071 "
                                 f"needed (mu={r.mu}, rho={r.rho}, beta={r.beta})")
        out.append(r)
        below = r.y_top
    return out


def read_layers(path: str | Path) -> list[LayerRow]:
    """Read and check a layers file (CSV, header ``y_top,mu,rho,beta``).

    Raises:
        ParameterError: The file cannot be read, or :func:`parse_layers` refuses it.
    """
    try:
        with open(path, newline="") as fh:
            rows = [{k.strip(): (v or "").strip() for k, v in row.items() if k}
                    for row in csv.DictReader(fh)]
    except (OSError, UnicodeDecodeError, csv.Error) as err:
        raise ParameterError(f"layers = {str(path)!r} cannot be read ({err})") from None
    return parse_layers(rows, f"layers file {path}")


#: Choices of the sweep's ``--model`` this module serves (1D).
SECTION_MODELS = ("section", "layers")


@dataclass(frozen=True)
class SliderMaterial:
    """A slider made of layers and/or profiles (the ``layers`` model).

    Attributes:
        rows: Layers from the interface up (empty: one layer ``H, 1, 1, beta`` of the params).
        profiles: ``{"mu" | "rho" | "beta": Profile}`` replacing that column in every layer.
    """

    rows: tuple[LayerRow, ...] = ()
    profiles: tuple[tuple[str, Profile], ...] = ()

    def layer_rows(self, H: float, beta: float) -> list[LayerRow]:  # noqa: N803
        """The rows, or the homogeneous slider of height ``H``."""
        return list(self.rows) or [LayerRow(H, 1.0, 1.0, beta)]

    def check(self, H: float) -> None:  # noqa: N803
        """Raise unless every profile stays in its range on the slider, ``0 <= y <= top``.

        ``top`` is the last layer's ``y_top``, or ``H`` without a layers file; the ranges are
        those of :class:`forms.models.section.Layer` (``mu, rho > 0``, ``0 < beta <
        1/sqrt(2)``), checked here so that a scene refuses a bad profile before any work.

        Raises:
            ParameterError: One line naming the option, its range and where it leaves it.
        """
        top = self.rows[-1].y_top if self.rows else H
        for name, prof in self.profiles:
            prof.check(0.0, top, 0.0, MATERIAL_HIGH[name])

    def as_dict(self) -> dict[str, object]:
        """JSON-friendly description (for a run's record)."""
        return {"layers": [list(map(float, (r.y_top, r.mu, r.rho, r.beta))) for r in self.rows],
                "profiles": {name: prof.text for name, prof in self.profiles}}


def slider_material(model: str, layers: str | None = None, mu: str | None = None,
                    rho: str | None = None, beta: str | None = None, *,
                    H: float) -> SliderMaterial | None:  # noqa: N803
    """The slider of the options ``--model``, ``--layers FILE``, ``--mu/rho/beta-profile EXPR``.

    ``H`` is the slider's height without a layers file (``--H``): the profiles are checked
    on the slider (:meth:`SliderMaterial.check`).

    Returns:
        ``None`` for ``model = "section"`` (the homogeneous slider of the params), else the
        checked :class:`SliderMaterial`.

    Raises:
        ParameterError: An unknown model, layer options without ``--model layers``,
            ``--model layers`` without any, or a bad file or expression, or a profile out of
            its range on the slider (one line).
    """
    exprs = {"mu": mu, "rho": rho, "beta": beta}
    given = [f"--{n}-profile" for n, v in exprs.items() if v is not None]
    given += ["--layers"] if layers is not None else []
    if model not in SECTION_MODELS:
        raise ParameterError(f"--model = {model!r} is not one of {', '.join(SECTION_MODELS)}")
    if model == "section":
        if given:
            raise ParameterError(f"{given[0]} needs --model layers (--model is 'section')")
        return None
    if not given:
        raise ParameterError("--model layers needs --layers FILE or a --mu/--rho/--beta-profile "
                             "expression of y")
    rows = tuple(read_layers(layers)) if layers is not None else ()
    profiles = tuple((n, Profile(v, f"--{n}-profile")) for n, v in exprs.items()
                     if v is not None)
    material = SliderMaterial(rows, profiles)
    material.check(H)
    return material


def homogeneous_params(params: Params, material: SliderMaterial) -> Params | None:
    """``params`` of the one homogeneous layer ``material`` describes, or ``None``.

    One row with ``mu = rho = 1`` and no profile is the homogeneous slider of height
    ``y_top`` and ratio ``beta`` (the exact roots of :mod:`analytic.physics.finite_h` apply).
    """
    if material.profiles or len(material.rows) != 1:
        return None
    row = material.rows[0]
    if row.mu != 1.0 or row.rho != 1.0:
        return None
    return params.replace(H=row.y_top, beta=row.beta)
