"""Assembly of a closed loop: components, their interfaces, the connections, and a scenario's wiring.

One wiring for every master (:mod:`~sideslip.cosim.master`, :mod:`~sideslip.cosim.libcosim_master`)
and the SSP export (:mod:`~sideslip.cosim.ssp`):

* Connections by contract name: an input takes the output of the same name from another
  component (plus the renames of :data:`INPUT_ALIASES`, ``Mz_cmd -> Mz_dyc``); explicit
  ``connections`` override and resolve ambiguity (e.g. which estimator feeds the controller).
  Unconnected inputs keep their start values.
* A scenario's loop (:func:`scenario_components`): driver, plant and sensors configured from the
  scenario, then the estimators and the controller, each FMU receiving the scenario's vehicle and
  every scenario hint that matches one of its parameters (``Ts``, ``mu``, ...), so adding an
  estimator to a run is naming it.  When several estimators run, the first one feeds the
  controller unless told otherwise.  The controller's source also feeds its ``beta_valid`` (an
  estimator's ``valid``; the truth leaves it true) and ``yaw_rate_hat`` (the truth: the plant's
  yaw rate), and the controller is set to feed back that yaw rate (``yaw_rate_source`` 1) rather
  than the gyro's, unless the parameters say otherwise.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..fmi.build import DEFAULT_OUT, ensure_fmus
from ..fmi.catalogue import CATALOGUE, fmu_names, fmu_spec
from ..params import ParameterError, declared_fields, did_you_mean, one_of, parse_assignment
from ..scenarios import Scenario, scenario_params

__all__ = ["Component", "Interface", "MasterError", "INPUT_ALIASES", "PLANT", "SENSORS", "DRIVER", "TRUTH_SOURCE",
           "interface_of", "resolve_connections", "fmu_paths", "numeric_parameters", "estimator_instances",
           "scenario_components"]

INPUT_ALIASES = {"Mz_dyc": ("Mz_cmd",)}
"""Input name -> output names that feed it besides the equal name (the renames of the contract, docs/design.md)."""

PLANT, SENSORS, DRIVER = "VehiclePlant", "VehicleSensors", "ManeuverDriver"
"""The FMUs of every scenario loop (instances ``plant``, ``sensors``, ``driver``)."""

TRUTH_SOURCE = {"beta": "beta_hat", "vx": "vx_hat", "yaw_rate": "yaw_rate_hat"}
"""Plant truth -> controller input when the controller runs on the true sideslip (``control_source="truth"``)."""


class MasterError(RuntimeError):
    """A co-simulation could not be set up or an FMU call failed."""


@dataclass
class Component:
    """One FMU instance in a co-simulation.

    Parameters
    ----------
    fmu : str
        FMU name from the catalogue (``VehiclePlant``) or the path of an ``.fmu`` file.
    name : str, optional
        Instance name (default: the FMU name); record fields are ``<name>.<variable>``.
    parameters : dict
        Parameter values by variable name, set before initialisation.
    """

    fmu: str
    name: str | None = None
    parameters: dict = field(default_factory=dict)

    def __post_init__(self):
        if self.name is None:
            self.name = Path(self.fmu).stem


# ---------------------------------------------------------------------------------------- wiring
@dataclass(frozen=True)
class Interface:
    """The ports of one instance: Real and Boolean outputs, inputs by name -> type."""

    name: str
    outputs_real: tuple
    outputs_bool: tuple
    inputs: dict


def interface_of(name: str, md) -> Interface:
    """Ports of instance ``name`` from an fmpy model description."""
    outs = [v for v in md.modelVariables if v.causality == "output"]
    return Interface(name, tuple(v.name for v in outs if v.type == "Real"),
                     tuple(v.name for v in outs if v.type == "Boolean"),
                     {v.name: v.type for v in md.modelVariables if v.causality == "input"})


def resolve_connections(interfaces, explicit=()):
    """Source of every input (see module docstring).

    Parameters
    ----------
    interfaces : list of Interface
        In component order.
    explicit : iterable of (str, str)
        ``("src_instance.output", "dst_instance.input")`` pairs overriding the match by name.

    Returns
    -------
    links : dict
        ``(instance, input) -> (source instance, output, "Real" | "Boolean")`` in component order.
    unconnected : list of str
        ``instance.input`` with no source (they keep their start values).

    Raises
    ------
    MasterError
        Unknown instance or port, ambiguous source, or a type mismatch.
    """
    by_name = {i.name: i for i in interfaces}
    providers: dict[str, list] = {}
    for itf in interfaces:
        for name in itf.outputs_real:
            providers.setdefault(name, []).append((itf.name, name, "Real"))
        for name in itf.outputs_bool:
            providers.setdefault(name, []).append((itf.name, name, "Boolean"))
    chosen = {}
    for src, dst in explicit:
        si, _, so = src.partition(".")
        di, _, dn = dst.partition(".")
        src_itf, dst_itf = by_name.get(si), by_name.get(di)
        if src_itf is None or dst_itf is None:
            raise MasterError(f"connection {src} -> {dst}: unknown instance (known: {', '.join(by_name)})")
        if so not in src_itf.outputs_real + src_itf.outputs_bool:
            raise MasterError(f"connection {src} -> {dst}: {si} has no output {so!r}")
        if dn not in dst_itf.inputs:
            raise MasterError(f"connection {src} -> {dst}: {di} has no input {dn!r}")
        chosen[(di, dn)] = (si, so, "Real" if so in src_itf.outputs_real else "Boolean")
    links, unconnected = {}, []
    for itf in interfaces:
        for name, kind in itf.inputs.items():
            if (itf.name, name) in chosen:
                src = chosen[(itf.name, name)]
            else:
                cands = [p for alias in (name, *INPUT_ALIASES.get(name, ())) for p in providers.get(alias, [])
                         if p[0] != itf.name]
                if not cands:
                    unconnected.append(f"{itf.name}.{name}")
                    continue
                if len(cands) > 1:
                    opts = ", ".join(f"{i}.{o}" for i, o, _ in cands)
                    raise MasterError(f"{itf.name}.{name} could come from {opts}: add an explicit connection")
                src = cands[0]
            if src[2] != kind:
                raise MasterError(f"{src[0]}.{src[1]} ({src[2]}) cannot feed {itf.name}.{name} ({kind})")
            links[(itf.name, name)] = src
    return links, unconnected


def fmu_paths(components, fmu_dir: str | Path = DEFAULT_OUT) -> dict[str, Path]:
    """FMU file of every component by instance name (catalogue names built/rebuilt on demand)."""
    by_name = [c.fmu for c in components if not str(c.fmu).endswith(".fmu")]
    paths = ensure_fmus(sorted(set(by_name)), fmu_dir) if by_name else {}
    return {c.name: Path(c.fmu) if str(c.fmu).endswith(".fmu") else paths[c.fmu] for c in components}


def numeric_parameters(component: Component) -> dict:
    """A component's parameters as Real, Integer and Boolean values only, for hosts that cannot set Strings
    (:meth:`~sideslip.fmi.catalogue.FmuSpec.numeric_parameters` for catalogue FMUs; other FMUs' as given).

    Raises
    ------
    MasterError
        For a String value that has no numeric form.
    """
    name = Path(component.fmu).stem
    try:
        params = fmu_spec(name).numeric_parameters(component.parameters) if name in CATALOGUE else \
            dict(component.parameters)
    except ParameterError as exc:
        raise MasterError(f"{component.name}: {exc}") from None
    text = [k for k, v in params.items() if isinstance(v, str)]
    if text:
        raise MasterError(f"{component.name}: String parameters {', '.join(text)} have no numeric form")
    return params


# ---------------------------------------------------------------------------------------- scenarios
def _auto_params(fmu: str, scenario: Scenario) -> dict:
    """Parameters an estimator/controller FMU takes from the scenario (vehicle and hints)."""
    return scenario_params(fmu_spec(fmu).config_class, scenario)


def estimator_instances(estimators) -> list[tuple[str, str]]:
    """``(instance, FMU name)`` of estimator specs ``"FMU"`` or ``"instance=FMU"``."""
    return [parse_assignment(e, "estimator", "FMU or instance=FMU") if "=" in e else (e, e) for e in estimators]


def scenario_components(scenario: Scenario, estimators=(), controller: str | None = None,
                        params: dict | None = None, control_source: str | None = None):
    """Components and explicit connections of a scenario run.

    Parameters
    ----------
    scenario : Scenario
    estimators : iterable of str
        Estimator FMU names (instance name = FMU name), or ``"instance=FMU"`` to run one FMU
        several times under different names (e.g. ``"srkf=Nguyen2012DACMRKF"``).
    controller : str, optional
        Controller FMU name (instance ``controller``).
    params : dict, optional
        ``{"instance.parameter": value}`` overrides of FMU parameters.
    control_source : str, optional
        Estimator instance feeding the controller (default: the first), or ``"truth"``: the
        plant's true ``beta`` and ``vx`` (the default without estimators).

    Returns
    -------
    list of Component, list of (str, str)
    """
    pairs = estimator_instances(estimators)
    estimators = [inst for inst, _ in pairs]
    known = set(fmu_names("estimator"))
    for _, fmu in pairs:
        if fmu not in known:
            raise KeyError(one_of(fmu, known, "estimator"))
    comps = [Component(DRIVER, "driver", scenario.driver_params()),
             Component(PLANT, "plant", scenario.plant_params()),
             Component(SENSORS, "sensors", scenario.sensor_params())]
    comps += [Component(fmu, inst, _auto_params(fmu, scenario)) for inst, fmu in pairs]
    connections = []
    if controller:
        if controller not in fmu_names("controller"):
            raise KeyError(one_of(controller, fmu_names("controller"), "controller"))
        comps.append(Component(controller, "controller", _auto_params(controller, scenario)))
        inputs = set(fmu_spec(controller).inputs)
        source = control_source or (estimators[0] if estimators else "truth")
        if not inputs & set(TRUTH_SOURCE.values()):
            pass                                     # the controller estimates for itself
        elif source == "truth":
            for truth, name in TRUTH_SOURCE.items():
                if name in inputs:
                    connections.append((f"plant.{truth}", f"controller.{name}"))
            if "mu_hat" in inputs:                   # the road's friction as the truth's friction estimate
                connections.append(("driver.mu", "controller.mu_hat"))
        elif source not in dict(pairs):
            raise KeyError(f"control source {source!r}: use 'truth' or one of the estimators {', '.join(estimators)}")
        else:
            outputs = set(fmu_spec(dict(pairs)[source]).outputs)
            if len(estimators) > 1:
                for name in sorted(inputs & outputs):
                    connections.append((f"{source}.{name}", f"controller.{name}"))
            if "beta_valid" in inputs and "valid" in outputs:
                connections.append((f"{source}.valid", "controller.beta_valid"))
            if "beta_std" in inputs and "beta_hat_std" in outputs:
                connections.append((f"{source}.beta_hat_std", "controller.beta_std"))
        if "yaw_rate_hat" in inputs and "yaw_rate_source" in {f.name for f, _ in
                                                             declared_fields(fmu_spec(controller).config_class)}:
            comps[-1].parameters.setdefault("yaw_rate_source", 1)     # its source provides an estimated yaw rate
    for key, value in (params or {}).items():
        inst, _, name = key.partition(".")
        match = [c for c in comps if c.name == inst]
        if not match or not name:
            raise KeyError(f"parameter override {key!r}: use <instance>.<parameter> with instance one of "
                           + ", ".join(c.name for c in comps) + did_you_mean(inst, [c.name for c in comps]))
        known = fmu_spec(match[0].fmu).parameter_names
        if name not in known:
            raise KeyError(f"parameter override {key!r}: " + one_of(name, known, f"parameter of {match[0].fmu}"))
        match[0].parameters[name] = value
    return comps, connections
