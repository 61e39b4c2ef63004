"""The public API has one shape across the four systems: ``optinav.<system>.simulate`` and ``calibrate`` (or
``estimate`` for attitude), returning the system's data / result types."""

import importlib
import inspect

import pytest

from optinav.core.results import Result

SYSTEMS = {"multipos": "calibrate", "rins": "calibrate", "gfimu": "calibrate", "attitude": "estimate"}


@pytest.mark.parametrize("system", sorted(SYSTEMS))
def test_each_system_has_simulate_and_its_fit(system):
    mod = importlib.import_module(f"optinav.{system}")
    for name in ("simulate", SYSTEMS[system]):
        assert name in mod.__all__, f"optinav.{system}.{name} not exported"
        assert inspect.isfunction(getattr(mod, name)), f"optinav.{system}.{name} is not a function"
    fit = getattr(mod, SYSTEMS[system])
    ret = inspect.signature(fit).return_annotation
    ret = eval(ret, vars(inspect.getmodule(fit))) if isinstance(ret, str) else ret
    assert isinstance(ret, type) and issubclass(ret, Result), f"optinav.{system}.{fit.__name__} returns {ret}"


def test_module_constants_stay_importable():
    """The package attribute ``simulate`` is the function; the module's names still import by their path."""
    from optinav.attitude.simulate import PAPER_SITE
    from optinav.multipos.simulate import SCHEMES
    from optinav.rins.simulate import PAPER_TABLE3

    assert PAPER_SITE and SCHEMES and len(PAPER_TABLE3) == 6
