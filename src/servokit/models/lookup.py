"""Name-or-file lookups: a catalogue plant or book controller by name, else a TOML file.

This module sits above :mod:`~servokit.models.catalogue`, :mod:`~servokit.models.controllers`
and :mod:`~servokit.models.files`, which import none of it (the old circle
catalogue -> files -> controllers -> catalogue is gone).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from servokit._lazy import control
from servokit.errors import ServokitValueError
from servokit.models.catalogue import CATALOGUE
from servokit.models.controllers import CONTROLLERS, RATIONAL_CONTROLLERS
from servokit.models.files import load_controller, load_controller_rational, load_plant
from servokit.models.modal import ModalPlant
from servokit.models.rational import RationalTF

__all__ = ["get_plant", "get_discrete_controller", "get_discrete_rational"]


def get_plant(name_or_file: str | Path) -> ModalPlant:
    """A catalogue plant by name (``hdd-benchmark``, ...) or a plant TOML file by path.

    Parameters
    ----------
    name_or_file : str or Path
        A key of :data:`CATALOGUE` (``"hdd-benchmark"``, ``"hdd-sampled-data"``,
        ``"vcm-dual-stage"``, ``"pzt-active-suspension"``, ``"svm-head-plant"``,
        ``"galvano-scanner"``), or the path of a plant file (a ``.toml`` name or an existing
        file; :func:`~servokit.models.files.load_plant`).

    Returns
    -------
    ModalPlant
        A new copy of the catalogue plant, or the plant loaded from the file.

    Raises
    ------
    ServokitValueError
        If the name is neither a catalogue key nor a plant file; a file's own errors as
        :class:`~servokit.models.files.PlantFileError`.
    """
    key = str(name_or_file)
    if key in CATALOGUE:
        return CATALOGUE[key]()
    path = Path(key)
    if path.suffix == ".toml" or path.exists():
        return load_plant(path)
    raise ServokitValueError(
        f"unknown plant {key!r}: choose one of {', '.join(CATALOGUE)} or give a .toml plant file"
    )


def get_discrete_controller(name_or_file: str, dt: float | None = None) -> control.TransferFunction:
    """A book controller by name (``eq-4.69``, ...) or a controller TOML file, checked discrete.

    With ``dt`` given, the controller's sampling period must equal it.

    Parameters
    ----------
    name_or_file : str
        A key of ``CONTROLLERS`` (``"eq-4.69"``, ``"fig-4.57"``, ``"table-5.2"``,
        ``"hdd-benchmark"``; each at its book sampling period) or the path of a controller TOML file
        (:func:`~servokit.models.files.load_controller`).
    dt : float, optional
        Required sampling period [s] (matched to a relative 1e-9); not checked if omitted.

    Returns
    -------
    control.TransferFunction
        The discrete controller.

    Raises
    ------
    ServokitValueError
        If the controller is continuous or its period differs from ``dt``; a file's own
        errors as :class:`~servokit.models.files.PlantFileError`.
    """
    if name_or_file in CONTROLLERS:
        ctrl = CONTROLLERS[name_or_file]()
    else:
        ctrl = load_controller(name_or_file)
    return _checked_discrete(name_or_file, ctrl, dt)


def get_discrete_rational(name_or_file: str, dt: float | None = None) -> RationalTF:
    """:func:`get_discrete_controller` as numpy coefficients, python-control left unloaded.

    A controller file and the zeros/poles/gain book controllers
    (:data:`~servokit.models.controllers.RATIONAL_CONTROLLERS`) are read without importing
    python-control (a command's start-up, issue 23); the others are built by python-control
    and converted.

    Parameters
    ----------
    name_or_file : str
        As :func:`get_discrete_controller`.
    dt : float, optional
        Required sampling period [s], as :func:`get_discrete_controller`.

    Returns
    -------
    RationalTF
        The controller :func:`get_discrete_controller` returns (``.to_control()``).

    Raises
    ------
    ServokitValueError
        As :func:`get_discrete_controller`.
    """
    if name_or_file in RATIONAL_CONTROLLERS:
        ctrl = RATIONAL_CONTROLLERS[name_or_file]()
    elif name_or_file in CONTROLLERS:
        ctrl = RationalTF.from_control(CONTROLLERS[name_or_file]())
    else:
        ctrl = load_controller_rational(name_or_file)
    return _checked_discrete(name_or_file, ctrl, dt)


def _checked_discrete(name_or_file: str, ctrl: Any, dt: float | None) -> Any:
    """``ctrl`` if discrete and (with ``dt``) at that period, else a one-line error."""
    if ctrl.dt is None or ctrl.dt is True or not ctrl.dt:
        raise ServokitValueError(
            f"controller {name_or_file} is continuous; give a discrete one (a 'dt' field), "
            f"or one of {', '.join(CONTROLLERS)}"
        )
    if dt is not None and abs(ctrl.dt - dt) > 1e-9 * dt:
        raise ServokitValueError(
            f"controller {name_or_file} has dt = {ctrl.dt:g} s; it must match the sampling "
            f"period {dt:g} s"
        )
    return ctrl
