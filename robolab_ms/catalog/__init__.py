"""The object catalog: every object a scene may place, with its physical and descriptive metadata.

The catalog is data (assets/catalog.yaml), read and checked by `.schema`; procedural shapes in `.procedural`,
packaged meshes in `.meshes`, looks in `.appearance`, `robolab catalog build` in `.build`, the check and contact
sheet in `.check`, `robolab catalog add` in `.add`.
"""

from robolab_ms.catalog.schema import (
    COLOR_NAMES,
    DROID_GRIPPER_OPENING,
    OBJECT_CLASSES,
    REAL_SHAPES,
    SHAPE_KINDS,
    Catalog,
    CatalogObject,
    load_catalog,
    narrowest_width,
    read_catalog,
    user_catalog_files,
)

__all__ = [
    "COLOR_NAMES",
    "DROID_GRIPPER_OPENING",
    "OBJECT_CLASSES",
    "REAL_SHAPES",
    "SHAPE_KINDS",
    "Catalog",
    "CatalogObject",
    "load_catalog",
    "narrowest_width",
    "read_catalog",
    "user_catalog_files",
]
