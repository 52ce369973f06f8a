"""Self-contained FMI 2.0 co-simulation FMUs built from generated C with the system's compiler.

One builder for the controller FMU (:func:`hydropwa.control.export_fmu`) and the axis FMU
(:func:`hydropwa.simulation.export_axis_fmu`): a model file (variables, ``hp_model_*``
functions) is inserted into the FMI 2.0 interface ``_c/fmi2_cs.c`` (or FMI 3.0 ``fmi3_cs.c``),
followed by the instance core both interfaces share (``_c/fmi_core.c``: reading, writing and
stepping the model once for both standards), compiled into the platform
binary of this machine, and zipped with ``modelDescription.xml`` and the sources (so a user
rebuilds for another platform, or a tool compiles the source-code FMU itself). The export
needs a C compiler only: no Python, FMI headers or build system (the FMI 2.0 types and
signatures are written out in ``fmi2_cs.c``).
"""

from __future__ import annotations

import hashlib
import os
import platform
import shutil
import subprocess
import sys
import uuid
import zipfile
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from xml.sax.saxutils import quoteattr

from .._errors import HydropwaError
from .._io import atomic_path, check_output, scratch_folder

__all__ = [
    "FmuVariable",
    "FmuBuildError",
    "build_fmu",
    "find_compiler",
    "fmi2_source",
    "fmi3_source",
]

#: flags of the FMU's binary; contraction off so it computes what the package's tests check
CFLAGS = ("-std=c99", "-O2", "-ffp-contract=off", "-shared", "-fPIC")

#: SI units used by the FMUs, as FMI BaseUnit exponents
_UNITS = {
    "m": {"m": 1},
    "m/s": {"m": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2},
    "Pa": {"kg": 1, "m": -1, "s": -2},
    "N": {"kg": 1, "m": 1, "s": -2},
    "s": {"s": 1},
}


class FmuBuildError(HydropwaError, RuntimeError):
    """An FMU cannot be built here (no C compiler, or the compiler failed)."""


@dataclass(frozen=True)
class FmuVariable:
    """One Real variable of an FMU (value reference = its position in the list).

    ``causality``: ``input``, ``output`` or ``parameter``; ``variability``: ``continuous``,
    ``discrete`` or ``fixed``; ``start`` the start value (inputs and parameters), ``unit`` an
    SI unit of :data:`_UNITS` or ``""``.
    """

    name: str
    causality: str
    variability: str
    start: float | None
    unit: str
    description: str


def find_compiler() -> str:
    """Path of the C compiler (``$CC``, else gcc, cc, clang on PATH); one-line error if none."""
    names = [os.environ["CC"]] if os.environ.get("CC") else ["gcc", "cc", "clang"]
    for name in names:
        path = shutil.which(name)
        if path:
            return path
    raise FmuBuildError(
        f"building an FMU needs a C compiler; none of {', '.join(names)} is on PATH "
        "(install gcc, or set CC)"
    )


def _platform() -> tuple[str, str]:
    """FMI 2.0 binaries folder and library suffix of this machine."""
    bits = "64" if sys.maxsize > 2**32 else "32"
    if sys.platform.startswith("linux"):
        return f"linux{bits}", ".so"
    if sys.platform == "darwin":
        return f"darwin{bits}", ".dylib"
    if sys.platform.startswith("win"):
        return f"win{bits}", ".dll"
    raise FmuBuildError(f"no FMI 2.0 platform name for {sys.platform} {platform.machine()}")


def _platform3() -> str:
    """FMI 3.0 platform tuple of this machine (``x86_64-linux``, ``aarch64-darwin``, ...)."""
    arch = {"amd64": "x86_64", "arm64": "aarch64"}.get(
        platform.machine().lower(), platform.machine().lower()
    )
    system = {"linux": "linux", "darwin": "darwin", "win32": "windows"}.get(
        "linux" if sys.platform.startswith("linux") else sys.platform
    )
    if system is None:
        raise FmuBuildError(f"no FMI 3.0 platform tuple for {sys.platform} {platform.machine()}")
    return f"{arch}-{system}"


def fmi2_source(model_c: str) -> str:
    """The FMI 2.0 co-simulation interface with ``model_c`` (the model file) inserted."""
    return _interface("fmi2_cs.c", model_c)


def fmi3_source(model_c: str) -> str:
    """The FMI 3.0 co-simulation interface with ``model_c`` (the model file) inserted."""
    return _interface("fmi3_cs.c", model_c)


def _interface(name: str, model_c: str) -> str:
    """The interface ``name`` with the model file and the shared instance core inserted."""
    folder = resources.files("hydropwa.simulation").joinpath("_c")
    template = folder.joinpath(name).read_text(encoding="utf-8")
    core = folder.joinpath("fmi_core.c").read_text(encoding="utf-8")
    return template.replace("@MODEL@", model_c).replace("@CORE@", core)


def _unit_definitions(units: list[str]) -> list[str]:
    """The ``<UnitDefinitions>`` lines of ``units`` (FMI 2.0 and 3.0 write them alike)."""
    if not units:
        return []
    lines = ["  <UnitDefinitions>"]
    for u in units:
        exps = " ".join(f'{k}="{e}"' for k, e in _UNITS[u].items())
        lines.append(f'    <Unit name="{u}"><BaseUnit {exps}/></Unit>')
    return lines + ["  </UnitDefinitions>"]


def _variable_attributes(reference: int, v: FmuVariable) -> str:
    """Name, value reference, causality, variability (and a parameter's initial) of ``v``."""
    attrs = (
        f'name={quoteattr(v.name)} valueReference="{reference}" causality="{v.causality}"'
        f' variability="{v.variability}"'
    )
    return attrs + (' initial="exact"' if v.causality == "parameter" else "")


def _model_description3(
    model_id: str,
    token: str,
    description: str,
    variables: list[FmuVariable],
    step_size: float,
) -> str:
    from .. import __version__  # deferred: hydropwa/__init__.py imports this package first

    units = sorted({v.unit for v in variables if v.unit} | {"s"})  # "s": the time variable
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<fmiModelDescription fmiVersion="3.0" modelName={quoteattr(model_id)}'
        f' instantiationToken="{token}"',
        f"  description={quoteattr(description)}",
        f'  generationTool="hydropwa {__version__}" variableNamingConvention="flat">',
        f'  <CoSimulation modelIdentifier="{model_id}" canHandleVariableCommunicationStepSize="true"'
        ' canGetAndSetFMUState="false" canSerializeFMUState="false" hasEventMode="false"'
        ' providesIntermediateUpdate="false"/>',
    ]
    lines += _unit_definitions(units)
    lines.append(f'  <DefaultExperiment startTime="0" stepSize="{step_size!r}"/>')
    lines.append("  <ModelVariables>")
    lines.append(
        f'    <Float64 name="time" valueReference="{len(variables)}" causality="independent"'
        ' variability="continuous" description="simulation time" unit="s"/>'
    )
    for i, v in enumerate(variables):
        attrs = _variable_attributes(i, v)
        attrs += f" description={quoteattr(v.description)}"
        if v.unit:
            attrs += f' unit="{v.unit}"'
        if v.start is not None:
            attrs += f' start="{float(v.start)!r}"'
        lines.append(f"    <Float64 {attrs}/>")
    lines.append("  </ModelVariables>")
    lines.append("  <ModelStructure>")
    outputs = [i for i, v in enumerate(variables) if v.causality == "output"]
    lines += [f'    <Output valueReference="{i}" dependencies=""/>' for i in outputs]
    lines += [f'    <InitialUnknown valueReference="{i}" dependencies=""/>' for i in outputs]
    lines.append("  </ModelStructure>")
    lines.append("</fmiModelDescription>")
    return "\n".join(lines) + "\n"


def _build_description3(model_id: str, compile_units: list[str]) -> str:
    files = "\n".join(f'      <SourceFile name="{f}"/>' for f in compile_units)
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n<fmiBuildDescription fmiVersion="3.0">\n'
        f'  <BuildConfiguration modelIdentifier="{model_id}">\n'
        f'    <SourceFileSet language="C99">\n{files}\n    </SourceFileSet>\n'
        "  </BuildConfiguration>\n</fmiBuildDescription>\n"
    )


def _model_description(
    model_id: str,
    guid: str,
    description: str,
    variables: list[FmuVariable],
    source_files: list[str],
    step_size: float,
    interpolate_inputs: bool,
) -> str:
    from .. import __version__  # deferred: hydropwa/__init__.py imports this package first

    units = sorted({v.unit for v in variables if v.unit})
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        f'<fmiModelDescription fmiVersion="2.0" modelName={quoteattr(model_id)} guid="{guid}"',
        f"  description={quoteattr(description)}",
        f'  generationTool="hydropwa {__version__}" variableNamingConvention="flat"'
        ' numberOfEventIndicators="0">',
        f'  <CoSimulation modelIdentifier="{model_id}" canHandleVariableCommunicationStepSize="true"'
        ' canBeInstantiatedOnlyOncePerProcess="false" canNotUseMemoryManagementFunctions="false"'
        ' canGetAndSetFMUstate="false" canSerializeFMUstate="false"'
        f' canInterpolateInputs="{str(interpolate_inputs).lower()}">',
        "    <SourceFiles>",
        *(f'      <File name="{f}"/>' for f in source_files),
        "    </SourceFiles>",
        "  </CoSimulation>",
    ]
    lines += _unit_definitions(units)
    lines.append(f'  <DefaultExperiment startTime="0" stepSize="{step_size!r}"/>')
    lines.append("  <ModelVariables>")
    for i, v in enumerate(variables):
        attrs = _variable_attributes(i, v)
        real = ""
        if v.unit:
            real += f' unit="{v.unit}"'
        if v.start is not None:
            real += f' start="{float(v.start)!r}"'
        lines.append(f"    <ScalarVariable {attrs} description={quoteattr(v.description)}>")
        lines.append(f"      <Real{real}/>")
        lines.append("    </ScalarVariable>")
    lines.append("  </ModelVariables>")
    lines.append("  <ModelStructure>")
    outputs = [i + 1 for i, v in enumerate(variables) if v.causality == "output"]
    lines.append("    <Outputs>")
    lines += [f'      <Unknown index="{i}" dependencies=""/>' for i in outputs]
    lines.append("    </Outputs>")
    lines.append("    <InitialUnknowns>")
    lines += [f'      <Unknown index="{i}" dependencies=""/>' for i in outputs]
    lines.append("    </InitialUnknowns>")
    lines.append("  </ModelStructure>")
    lines.append("</fmiModelDescription>")
    return "\n".join(lines) + "\n"


def build_fmu(
    path: str | os.PathLike,
    model_id: str,
    description: str,
    variables: list[FmuVariable],
    sources: dict[str, str],
    compile_units: list[str],
    *,
    step_size: float,
    interpolate_inputs: bool = False,
    fmi_version: str = "2.0",
    overwrite: bool = False,
) -> Path:
    """Compile ``sources`` and zip the FMU at ``path`` (refuses an existing file without ``overwrite``).

    Parameters
    ----------
    path : path-like
        The ``.fmu`` file.
    model_id : str
        FMI model identifier (a C identifier; the binary's name).
    description : str
        One line for ``modelDescription.xml``.
    variables : list of FmuVariable
        The Real variables in value-reference order.
    sources : dict
        File name → text of every source file (``sources/`` of the FMU).
    compile_units : list of str
        The files of ``sources`` to compile (the others are included).
    step_size : float
        Default communication step [s].
    interpolate_inputs : bool
        The model takes the inputs' first derivatives (``canInterpolateInputs``, FMI 2.0).
    fmi_version : str
        ``"2.0"`` or ``"3.0"`` (the compile units then use the interface of that version).
    overwrite : bool
        Replace an existing file.

    Raises
    ------
    FmuBuildError
        No C compiler, or it failed (its first error line in the message).
    """
    path = Path(path)
    if path.suffix.lower() != ".fmu":
        raise FmuBuildError(f"{path}: an FMU file must end in .fmu")
    check_output(path, overwrite)
    if fmi_version not in ("2.0", "3.0"):
        raise FmuBuildError(f"FMI version {fmi_version!r}: choose 2.0 or 3.0")
    cc = find_compiler()
    folder, suffix = _platform()
    if fmi_version == "3.0":
        folder = _platform3()
    digest = hashlib.sha256("".join(sources[k] for k in sorted(sources)).encode()).hexdigest()
    guid = "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, f"hydropwa:{model_id}:{digest}")) + "}"
    if fmi_version == "3.0":
        xml = _model_description3(model_id, guid, description, variables, step_size)
    else:
        xml = _model_description(
            model_id, guid, description, variables, compile_units, step_size, interpolate_inputs
        )
    # the interface checks the GUID it is instantiated with against its own
    sources = {
        k: (f'#define HP_GUID "{guid}"\n' + v) if k.endswith(("_fmi2.c", "_fmi3.c")) else v
        for k, v in sources.items()
    }
    with scratch_folder("fmu") as tmp:  # a compile killed midway is cleaned by the next one
        src = Path(tmp) / "sources"
        src.mkdir()
        for name, text in sources.items():
            (src / name).write_text(text, encoding="utf-8")
        lib = Path(tmp) / f"{model_id}{suffix}"
        cmd = [
            cc,
            *CFLAGS,
            f"-I{src}",
            "-o",
            str(lib),
            *(str(src / u) for u in compile_units),
            "-lm",
        ]
        proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if proc.returncode != 0:
            first = next((ln for ln in proc.stderr.splitlines() if "error" in ln), proc.stderr)
            raise FmuBuildError(f"the C compiler {cc} failed to build the FMU: {first.strip()}")
        with atomic_path(path, overwrite=overwrite) as out:
            with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as z:
                z.writestr("modelDescription.xml", xml)
                z.write(lib, f"binaries/{folder}/{model_id}{suffix}")
                for name, text in sources.items():
                    z.writestr(f"sources/{name}", text)
                if fmi_version == "3.0":
                    z.writestr(
                        "sources/buildDescription.xml", _build_description3(model_id, compile_units)
                    )
    return path
