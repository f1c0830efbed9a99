"""What a robolab_ms USD stage is, for both directions (`.usd_export` writes one, `.usd_import` reads layouts
back): the file suffixes, the prim paths, the custom attributes of the robolab: namespace, the loader of the USD
modules (usd-core's `pxr`) and the stage check that runs USD's own validators.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from robolab_ms.errors import RoboLabError

USD_SUFFIXES = (".usda", ".usd", ".usdc")
WORLD = "/World"
PHYSICS_SCENE = "/PhysicsScene"
ATTR = {  # custom attributes of the robolab: namespace
    "name": "robolab:name", "catalog": "robolab:catalog", "rests_on": "robolab:restsOn", "level": "robolab:level",
    "role": "robolab:role", "scene": "robolab:scene", "description": "robolab:description",
    "jitter_xy": "robolab:jitterXy", "jitter_yaw": "robolab:jitterYawDeg", "background": "robolab:background",
    "table_rgba": "robolab:tableRgba", "table_material": "robolab:tableMaterial", "class": "robolab:class",
    "license": "robolab:license",
}  # fmt: skip
ANGLE_DECIMALS = 9  # degrees in the imported scene file (1e-9 degrees is far below the round trip's 1e-6)


def pxr_modules():
    """The USD modules (usd-core), with a clear error when they are missing."""
    try:
        from pxr import Gf, Sdf, Tf, Usd, UsdGeom, UsdPhysics, UsdShade, UsdValidation, Vt  # noqa: F401
    except ImportError as error:  # pragma: no cover - usd-core is pinned in requirements.lock
        raise RoboLabError(
            f"USD support needs the usd-core package ({error}). Install the pinned set-up with 'make setup'"
        ) from None
    import pxr

    return pxr


def check_suffix(path: Path, option: str) -> None:
    """RoboLabError unless `path` (given to `option`) names a USD file."""
    if path.suffix.lower() not in USD_SUFFIXES:
        raise RoboLabError(
            f"{option} {path}: a USD file ends in {', '.join(USD_SUFFIXES)}; give e.g. {path.with_suffix('.usda')}"
        )


def write_attribute(prim, key: str, value: Any, kind=None) -> None:
    """Author the custom attribute robolab:<key> (text unless `kind` says otherwise)."""
    pxr = pxr_modules()
    kind = kind or pxr.Sdf.ValueTypeNames.String
    prim.CreateAttribute(ATTR[key], kind, custom=True).Set(value)


def read_attribute(prim, key: str) -> Any:
    """The value of robolab:<key> on `prim`, None when not authored."""
    attribute = prim.GetAttribute(ATTR[key])
    return attribute.Get() if attribute and attribute.HasAuthoredValue() else None


def unique_name(name: str, taken: set[str]) -> str:
    """`name`, or `name_2`, `name_3`, ... if taken; the result joins `taken`."""
    candidate, index = name, 2
    while candidate in taken:
        candidate, index = f"{name}_{index}", index + 1
    taken.add(candidate)
    return candidate


STAGE_VALIDATORS = (
    "usdValidation:CompositionErrorTest", "usdValidation:StageMetadataChecker", "usdValidation:AttributeTypeMismatch",
    "usdGeomValidators:StageMetadataChecker", "usdGeomValidators:EncapsulationChecker",
    "usdUtilsValidators:MissingReferenceValidator", "usdPhysicsValidators:RigidBodyChecker",
    "usdPhysicsValidators:ColliderChecker", "usdShadeValidators:MaterialBindingApiAppliedValidator",
    "usdShadeValidators:MaterialBindingRelationships", "usdShadeValidators:ShaderSdrCompliance",
)  # fmt: skip


def validate_stage(path: Path) -> list[str]:
    """Open a USD file and check it: it composes without errors (every referenced asset found) and passes USD's
    own validators for stage metadata, geometry, physics bodies and colliders, and material bindings. Returns one
    line per finding (empty when it is good)."""
    pxr = pxr_modules()
    stage = pxr.Usd.Stage.Open(str(path))
    if stage is None:
        return [f"{path} does not open as a USD stage"]
    problems = [f"composition: {error}" for error in stage.GetCompositionErrors()]
    registry = pxr.UsdValidation.ValidationRegistry()
    validators = [registry.GetOrLoadValidatorByName(name) for name in STAGE_VALIDATORS]
    context = pxr.UsdValidation.ValidationContext([v for v in validators if v is not None])
    for error in context.Validate(stage):
        if error.GetType() in (pxr.UsdValidation.ValidationErrorType.Error, pxr.UsdValidation.ValidationErrorType.Warn):
            problems.append(f"{error.GetName()}: {error.GetMessage()}")
    return problems
