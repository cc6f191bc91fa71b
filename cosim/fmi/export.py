"""A scene exported as an FMI 2.0 co-simulation FMU (pythonfmu): ``cosim fmu export``.

The FMU packs the scene's text and its :class:`~cosim.fmi.spec.ExportSpec` as resources beside a
two-line slave module, a subclass of :class:`cosim.fmi.slave.SceneSlave` named after the FMU (its
model identifier). pythonfmu writes the model description without ``InitialUnknowns`` and without
units; the outputs are computed at initialization (initial ``calculated``), so they are added, and so
are the Real variables' units with their definitions. FMPy's validation of the model description
then finds nothing to report.
"""

from __future__ import annotations

import keyword
import os
import re
import tempfile
import zipfile
from collections.abc import Callable
from pathlib import Path
from xml.sax.saxutils import quoteattr

from cosim.errors import ScenarioError
from cosim.fmi.build import build_fmu
from cosim.fmi.slave import SCENE_FILE, SPEC_FILE
from cosim.fmi.spec import ExportSpec
from cosim.record.output import copy_file, output_folder, written_whole
from cosim.scenario import Scene

MODEL_DESCRIPTION = "modelDescription.xml"


MAX_IDENTIFIER = 200  # characters in a model identifier: it names files inside the FMU and as it is built


def model_identifier(output: Path) -> str:
    """The FMU's model identifier from its file name (``skip.fmu`` -> ``skip``): a C identifier, as
    FMI asks, since it names the FMU's binaries and functions."""
    # ASCII only: a C identifier has no other letters (\w kept skïp's ï: a Python name, no C one)
    name = re.sub(r"[^A-Za-z0-9_]", "_", output.stem)
    # a C identifier, and a Python class name for the slave (class.fmu made a class named class); and
    # not a dunder: the binary fetches the class as the module's attribute of that name, and a module's
    # own __class__ or __dict__ comes first (__builtins__ replaced the module's builtins), so that
    # __class__.fmu was written, and then could not be instantiated
    plain = name and not name[0].isdigit() and not keyword.iskeyword(name) and not name.startswith("__")
    return name if plain else f"fmu_{name}"


SLAVE_MODULE = '''"""A cosim scene as an FMI 2.0 co-simulation FMU (cosim fmu export), the scene in its resources."""

from cosim.fmi.slave import SceneSlave, hold_namespace

hold_namespace(globals())  # once per run of this text: see cosim.fmi.slave.hold_namespace


class {identifier}(SceneSlave):
    """Runs the scene in this FMU's resources (scene.yaml, export.json)."""
'''


def add_initial_unknowns(text: str) -> str:
    """The model description ``text`` with every output listed under ``ModelStructure/InitialUnknowns``."""
    outputs = re.search(r"<Outputs>(.*?)</Outputs>", text, re.S)
    if outputs is None or "<InitialUnknowns>" in text:
        return text
    unknowns = "".join(f"\n\t\t\t{u}" for u in re.findall(r"<Unknown [^>]*/>", outputs.group(1)))
    return text.replace("</Outputs>", f"</Outputs>\n\t\t<InitialUnknowns>{unknowns}\n\t\t</InitialUnknowns>", 1)


def add_units(text: str, spec: ExportSpec) -> str:
    """The model description ``text`` with each Real variable's unit (pythonfmu 0.7 writes none) and
    the units' definitions, which FMI 2.0 asks for every unit a variable names."""
    units = {v.name: v.unit for v in (*spec.parameters, *spec.outputs)
             if v.unit and getattr(v, "kind", "real") == "real"}
    if not units or "<UnitDefinitions>" in text:
        return text
    for name, unit in units.items():
        text = re.sub(rf'(<ScalarVariable name="{re.escape(name)}"[^>]*>\s*<Real)', rf"\1 unit={quoteattr(unit)}",
                      text, count=1)
    definitions = "".join(f"\n\t\t<Unit name={quoteattr(unit)}/>" for unit in sorted(set(units.values())))
    # FMI 2.0's order: CoSimulation, then UnitDefinitions, before the log categories and the variables
    return re.sub(r"(<CoSimulation [^>]*/>)", lambda m: f"{m.group(1)}\n\t<UnitDefinitions>{definitions}"
                  "\n\t</UnitDefinitions>", text, count=1)


def _rewrite_description(fmu: Path, edit: Callable[[str], str]) -> None:
    """Rewrite ``fmu`` with its model description passed through ``edit``."""
    with zipfile.ZipFile(fmu) as z:
        entries = [(info, z.read(info.filename)) for info in z.infolist()]
    text = next(data for info, data in entries if info.filename == MODEL_DESCRIPTION).decode("utf-8")
    part = fmu.with_name(fmu.name + ".part")
    with zipfile.ZipFile(part, "w", zipfile.ZIP_DEFLATED) as z:
        for info, data in entries:
            z.writestr(info, edit(text).encode("utf-8") if info.filename == MODEL_DESCRIPTION else data)
    part.replace(fmu)


def _fmu_used_by(scene: Scene, output: Path) -> tuple[str, str] | None:
    """The component of ``scene`` whose FMU file ``output`` is, by any name (a symbolic or hard link,
    another spelling of the path), and its key (``path``, or ``model`` for the FMU built from a
    model); or None. An FMU component holds its file as ``fmu_file`` on its class."""
    for name, config in scene.components.items():
        used = getattr(config.cls, "fmu_file", None)
        if not isinstance(used, Path):
            continue
        # resolved, for a path through a folder not made yet (sub/../inner.fmu, which exists() denies);
        # samefile for a hard link
        same = output.resolve() == used.resolve() or (output.exists() and used.exists()
                                                      and os.path.samefile(output, used))
        if same:
            return name, "path" if getattr(config.params, "path", None) is not None else "model"
    return None


def export_scene(scene: Scene, spec: ExportSpec, output: str | Path) -> Path:
    """Build the FMU ``output`` (a ``.fmu`` file) running ``scene`` as ``spec`` says."""
    output = Path(output)
    if output.suffix != ".fmu":
        raise ScenarioError(f"-o {output}: an FMU file name ends in .fmu", scene.source)
    if output.exists() and not zipfile.is_zipfile(output):
        raise ScenarioError(f"-o {output}: exists and is not an FMU; it is not replaced", scene.source)
    used = _fmu_used_by(scene, output)
    if used is not None:  # the exported FMU would hold a scene whose own FMU it had replaced
        name, key = used
        raise ScenarioError(f"-o {output}: is the FMU of component {name!r} (components.{name}.{key}); it is "
                            "not replaced", scene.source)
    identifier = model_identifier(output)
    if len(identifier) > MAX_IDENTIFIER:  # it names the FMU's module file and its binaries
        raise ScenarioError(f"-o {output}: an FMU's name (its model identifier) is at most {MAX_IDENTIFIER} "
                            f"characters (got {len(identifier)})", scene.source)
    with tempfile.TemporaryDirectory(prefix="cosim-export-") as tmp:
        folder = Path(tmp)
        # the module's name is its own (a scene called "json" must not import the standard library's
        # json in its place); the class, named as the FMU, is the model identifier
        script = folder / f"cosim_scene_{identifier}.py"
        # the same text for every scene exported under one name: PythonFMU runs one module of a name per
        # process, so two such FMUs in one scene share the first one's (each runs its own resources' scene)
        script.write_text(SLAVE_MODULE.format(identifier=identifier), encoding="utf-8")
        (folder / SCENE_FILE).write_text(scene.text, encoding="utf-8")
        (folder / SPEC_FILE).write_text(spec.to_json(), encoding="utf-8")
        built = build_fmu(script, folder / "out" / output.name, extra_files=[folder / SCENE_FILE, folder / SPEC_FILE],
                          state=True)
        _rewrite_description(built, lambda text: add_units(add_initial_unknowns(text), spec))
        # written whole beside the target, then renamed onto it: a disk that fills up leaves no broken
        # FMU, an FMU there before stays as it was, and the error names -o, not the build's folder
        with output_folder(output.parent), written_whole(output) as part:  # no folder left if failing
            copy_file(built, part)
    return output

