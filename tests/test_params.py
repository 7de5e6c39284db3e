import math

import numpy as np
import pytest

from analytic.params import ParameterError, Params, check_k

# Pure numpy (no MPI, no FE): the serial pass is enough.
pytestmark = pytest.mark.serial


@pytest.mark.parametrize(
    "field,value,needle",
    [
        ("beta", 0.0, "beta"),
        ("beta", 1 / math.sqrt(2), "beta"),
        ("beta", math.nan, "beta"),
        ("H", 0.0, "H"),
        ("H", -1.0, "H"),
        ("gamma", 0.0, "gamma"),
        ("f", -0.1, "f"),
        ("Delta", math.nan, "Delta"),
        ("alpha_pc", -1.0, "alpha_pc"),
        ("alpha_ld", -1.0, "alpha_ld"),
        ("bc", "free", "bc"),
    ],
)
def test_bad_parameter_named(field, value, needle):
    with pytest.raises(ParameterError, match=needle):
        Params(**{field: value})


def test_defaults_are_the_papers():
    p = Params()
    assert (p.f, p.gamma, p.beta, p.Delta, p.H, p.bc) == (0.3, 3.0, 0.5, 0.7, 0.5, "velocity")
    assert p.lame_lambda == pytest.approx(2.0)
    assert Params(H=math.inf).H == math.inf


@pytest.mark.parametrize("k", [0.0, -1.0, math.nan, math.inf])
def test_bad_k(k):
    with pytest.raises(ParameterError, match="k"):
        check_k([1.0, k])


def test_parse_k():
    from _cli import parse_k

    assert np.allclose(parse_k("0.5:2:4"), [0.5, 1.0, 1.5, 2.0])
    assert np.allclose(parse_k("0.5,1,2"), [0.5, 1.0, 2.0])
    for bad in ("a:b:c", "1:0.5:3", "0,1", "1:2"):
        with pytest.raises(ParameterError):
            parse_k(bad)
