"""The object catalog: every object a scene may place, with its physical and descriptive metadata.

The catalog is data (assets/catalog.yaml), read and checked by `.schema`; procedural shapes in `.procedural`,
modelled meshes in `.modelled`, packaged meshes in `.meshes`, looks in `.appearance`, `robolab catalog build` in
`.build`, the check and contact sheet in `.check`, `robolab catalog add` in `.add`, the table `robolab catalog list`
prints in `.listing`.
"""

from robolab_ms.catalog.schema import (
    COLOR_NAMES,
    OBJECT_CLASSES,
    REAL_SHAPES,
    SHAPE_KINDS,
    Catalog,
    CatalogObject,
    load_catalog,
    narrowest_width,
    read_catalog,
    shipped_catalog_file,
    user_catalog_files,
)

__all__ = [
    "COLOR_NAMES",
    "OBJECT_CLASSES",
    "REAL_SHAPES",
    "SHAPE_KINDS",
    "Catalog",
    "CatalogObject",
    "load_catalog",
    "narrowest_width",
    "read_catalog",
    "shipped_catalog_file",
    "user_catalog_files",
]
