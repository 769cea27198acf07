"""SSP 1.0 packages (System Structure and Parameterization) of a scenario's closed loop: write and read.

``export_ssp`` writes ``OUT.ssp``, a zip with

* ``SystemStructure.ssd``: one ``ssd:Component`` per instance (``source`` = its FMU under
  ``resources/``), a connector for every input, output and parameter with its type and unit,
  the scenario's parameter values as an inline ``ssv:ParameterSet`` binding per component (in
  numeric form by default, without String connectors: OMSimulator rejects those), the connections
  of :func:`~sideslip.cosim.assembly.resolve_connections` (the masters' own wiring), the unit
  definitions, OMSimulator's annotation of the system (its fixed-step master and step), and a
  ``DefaultExperiment`` (start 0, the scenario's stop time) whose OSP annotation gives libcosim the
  fixed communication step;
* ``resources/<FMU>.fmu``: each FMU used, once.

The package validates against the SSP 1.0 schema that fmpy ships (``fmpy.ssp.ssd.read_ssd``),
runs in libcosim (:func:`~sideslip.cosim.libcosim_master.run_libcosim_ssp`) and in the
OMSimulator program (:func:`~sideslip.cosim.omsimulator_master.run_omsimulator_ssp`), and can be
opened by other SSP-aware tools (Simulink's SSP import).  SSP 1.0 has no coupling
scheme: libcosim runs it as Jacobi, like ``run --master libcosim``.  :func:`read_experiment`
reads back what a master needs to run a package (start, stop, step).  This module owns the
SSP namespaces (:data:`NS`).
"""
from __future__ import annotations

import datetime
import zipfile
from pathlib import Path
from xml.etree.ElementTree import Element, SubElement, parse, register_namespace, tostring

from fmpy import read_model_description

from .. import __version__
from ..fmi.build import DEFAULT_OUT
from ..fmi.variables import format_value
from ..scenarios import Scenario, get_scenario
from .assembly import (Component, MasterError, fmu_paths, interface_of, numeric_parameters, resolve_connections,
                       scenario_components)

__all__ = ["export_ssp", "read_experiment", "NS"]

NS = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription",
      "ssc": "http://ssp-standard.org/SSP1/SystemStructureCommon",
      "ssv": "http://ssp-standard.org/SSP1/SystemStructureParameterValues",
      "osp": "http://opensimulationplatform.com/SSP/OSPAnnotations",
      "oms": "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd"}
for _prefix, _uri in NS.items():
    register_namespace(_prefix, _uri)

_KINDS = {"input": "input", "output": "output", "parameter": "parameter"}


def _q(tag: str) -> str:
    prefix, _, name = tag.partition(":")
    return f"{{{NS[prefix]}}}{name}"


def _typed(parent: Element, ns: str, var, value=None) -> Element:
    """``<ns:Real unit=.../>`` (connector) or ``<ns:Real value=.../>`` (parameter) for ``var``."""
    el = SubElement(parent, _q(f"{ns}:{var.type}"))
    unit = var.unit or (var.declaredType.unit if var.declaredType is not None else None)
    if value is None and var.type == "Real" and unit:
        el.set("unit", unit)
    if value is not None:
        el.set("value", format_value(var.type, value, var.name))
    return el


def _units(mds) -> Element | None:
    seen = {}
    for md in mds:
        for u in md.unitDefinitions:
            seen.setdefault(u.name, u)
    if not seen:
        return None
    units = Element(_q("ssd:Units"))
    for name, u in seen.items():
        el = SubElement(units, _q("ssc:Unit"), name=name)
        base = SubElement(el, _q("ssc:BaseUnit"))
        b = u.baseUnit
        if b is not None:
            for attr in ("kg", "m", "s", "A", "K", "mol", "cd", "rad"):
                exp = int(getattr(b, attr, 0) or 0)
                if exp:
                    base.set(attr, str(exp))
            if float(b.factor) != 1.0:
                base.set("factor", repr(float(b.factor)))
            if float(b.offset) != 0.0:
                base.set("offset", repr(float(b.offset)))
    return units


def export_ssp(out: str | Path, scenario: str | Scenario, estimators=(), controller: str | None = None,
               params: dict | None = None, control_source: str | None = None, overrides: dict | None = None,
               duration: float | None = None, step: float = 1e-3, fmu_dir: str | Path = DEFAULT_OUT,
               numeric: bool | None = None) -> Path:
    """Write the closed loop of a scenario as an SSP 1.0 package.

    Parameters
    ----------
    out : path
        The ``.ssp`` file to write (folders are created).
    scenario, estimators, controller, params, control_source
        As for :func:`~sideslip.cosim.assembly.scenario_components`.
    overrides : dict, optional
        Scenario overrides.
    duration : float, optional
        ``DefaultExperiment`` stop time [s] (default: the scenario's duration).
    step : float
        Fixed communication step [s] (OSP annotation for libcosim).
    fmu_dir : path
        Folder of the built FMUs (built on demand).
    numeric : bool, optional
        ``True``: parameters in their numeric form (:func:`~sideslip.cosim.assembly.numeric_parameters`) and
        no String connectors, which OMSimulator requires (raises :class:`~sideslip.cosim.assembly.MasterError`
        for a String without numeric form, e.g. a friction time table); ``False``: the Strings as given (for
        libcosim); ``None`` (default): numeric where every parameter has a numeric form, else the Strings.

    Returns
    -------
    Path
        ``out``.
    """
    sc = get_scenario(scenario, **(overrides or {})) if isinstance(scenario, str) else scenario
    comps, conns = scenario_components(sc, estimators, controller, params, control_source)
    if numeric is not False:
        try:
            comps = [Component(c.fmu, c.name, numeric_parameters(c)) for c in comps]
            numeric = True
        except MasterError:
            if numeric:
                raise
            numeric = False
    kinds = ("Real", "Integer", "Boolean") + (() if numeric else ("String",))
    paths = fmu_paths(comps, fmu_dir)
    mds = {c.name: read_model_description(str(paths[c.name])) for c in comps}
    links, _ = resolve_connections([interface_of(c.name, mds[c.name]) for c in comps], conns)

    root = Element(_q("ssd:SystemStructureDescription"), version="1.0", name=sc.name,
                   description=f"sideslip-fmu closed loop: {sc.description}",
                   generationTool=f"sideslip-fmu {__version__}",
                   generationDateAndTime=datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"))
    system = SubElement(root, _q("ssd:System"), name=sc.name)
    elements = SubElement(system, _q("ssd:Elements"))
    for c in comps:
        md = mds[c.name]
        comp = SubElement(elements, _q("ssd:Component"), name=c.name, type="application/x-fmu-sharedlibrary",
                          source=f"resources/{paths[c.name].name}")
        connectors = SubElement(comp, _q("ssd:Connectors"))
        by_name = {}
        for v in md.modelVariables:
            if v.causality in _KINDS and v.type in kinds:
                by_name[v.name] = v
                con = SubElement(connectors, _q("ssd:Connector"), name=v.name, kind=_KINDS[v.causality])
                if v.description:
                    con.set("description", v.description)
                _typed(con, "ssc", v)
        if c.parameters:
            binding = SubElement(SubElement(comp, _q("ssd:ParameterBindings")), _q("ssd:ParameterBinding"))
            pset = SubElement(SubElement(binding, _q("ssd:ParameterValues")), _q("ssv:ParameterSet"),
                              version="1.0", name=f"{c.name}_{sc.name}")
            plist = SubElement(pset, _q("ssv:Parameters"))
            for key, value in c.parameters.items():
                var = by_name.get(key)
                if var is None or var.causality != "parameter":
                    raise KeyError(f"{c.name}: no parameter {key!r}")
                _typed(SubElement(plist, _q("ssv:Parameter"), name=key), "ssv", var, value)
    connections = SubElement(system, _q("ssd:Connections"))
    for (dst, name), (src, output, _) in links.items():
        SubElement(connections, _q("ssd:Connection"), startElement=src, startConnector=output,
                   endElement=dst, endConnector=name)
    oms = SubElement(SubElement(SubElement(system, _q("ssd:Annotations")), _q("ssc:Annotation"),
                                type="org.openmodelica"), _q("oms:Annotations"))
    SubElement(SubElement(oms, _q("oms:SimulationInformation")), _q("oms:FixedStepMaster"), description="oms-ma",
               stepSize=repr(float(step)))
    units = _units(mds.values())
    if units is not None:
        root.append(units)
    experiment = SubElement(root, _q("ssd:DefaultExperiment"), startTime="0",
                            stopTime=repr(float(duration if duration is not None else sc.duration)))
    note = SubElement(SubElement(experiment, _q("ssd:Annotations")), _q("ssc:Annotation"),
                      type="com.opensimulationplatform")
    SubElement(SubElement(note, _q("osp:Algorithm")), _q("osp:FixedStepAlgorithm"), baseStepSize=repr(float(step)))

    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".part")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("SystemStructure.ssd", b'<?xml version="1.0" encoding="UTF-8"?>\n' + tostring(root))
        for path in sorted(set(paths.values())):
            z.write(path, f"resources/{path.name}")
    tmp.replace(out)
    return out


def read_experiment(ssd: str | Path) -> tuple[float, float | None, float | None]:
    """``(start, stop, step)`` of a ``SystemStructure.ssd`` [s]: its ``DefaultExperiment`` and the OSP
    fixed-step annotation (``None`` where the file gives none)."""
    root = parse(ssd).getroot()
    exp = root.find("ssd:DefaultExperiment", NS)
    algo = root.find("ssd:DefaultExperiment/ssd:Annotations/ssc:Annotation/osp:Algorithm/osp:FixedStepAlgorithm", NS)
    start = float(exp.get("startTime", 0.0)) if exp is not None else 0.0
    stop = float(exp.get("stopTime")) if exp is not None and exp.get("stopTime") is not None else None
    step = float(algo.get("baseStepSize")) if algo is not None else None
    return start, stop, step
