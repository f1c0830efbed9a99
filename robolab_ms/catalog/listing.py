"""The catalog as a table of text cells, one row per object: what `robolab catalog list` prints."""

from __future__ import annotations

from robolab_ms.agents.droid_model import RATED_OPENING
from robolab_ms.catalog.schema import SHAPE_KINDS, Catalog, CatalogObject, narrowest_width

GRASP_CLEARANCE = 0.005  # m: an object "fits" the open gripper with at least this much room on each side
LISTING_HEADER = ("object", "class", "shape", "size x y z (cm)", "grasp (cm)", "fits", "colours", "mass (kg)", "source")


def grasp_fit(width: float) -> str:
    """Whether an object this wide (m) fits the open DROID gripper: `yes` with GRASP_CLEARANCE to spare on each side,
    `tight` when only narrower than the opening, `no` otherwise."""
    if width <= RATED_OPENING - 2 * GRASP_CLEARANCE:
        return "yes"
    return "tight" if width < RATED_OPENING else "no"


def source_label(entry: CatalogObject) -> str:
    """Where an object comes from: its generator (procedural), the folder of its file (added with `robolab catalog
    add`) or its asset package."""
    if entry.is_procedural:
        return entry.source["generator"]
    if entry.is_modelled:
        return f"modelled {entry.source['generator']}"
    if entry.source["kind"] == "file":
        return f"file in {entry.folder}"
    return entry.source["package"]


def listing_rows(catalog: Catalog) -> list[tuple[str, ...]]:
    """LISTING_HEADER, then per object in name order: class, shape kind, size, graspable width, fit, colours, mass and source."""
    rows = [LISTING_HEADER]
    for name in catalog.names():
        entry = catalog[name]
        size = " x ".join(f"{d * 100:.1f}" for d in (entry.recorded_dimensions or entry.dimensions))
        width = narrowest_width(entry)
        rows.append(
            (
                name,
                entry.object_class,
                entry.shape,
                size,
                f"{width * 100:.1f}",
                grasp_fit(width),
                ",".join(entry.colors) or "-",
                f"{entry.mass:.3f}",
                source_label(entry),
            )
        )
    return rows


def listing_note(catalog: Catalog) -> str:
    """The line under the table: how many objects of each shape kind, and what `shape`, `grasp` and `fits` mean."""
    return (
        f"{len(catalog)} object(s): {shape_counts_text(catalog)}. shape: how the object's form was made ("
        + "; ".join(f"{kind}: {meaning}" for kind, meaning in SHAPE_KINDS.items())
        + "). grasp: the narrowest horizontal width as the object stands; fits: whether "
        f"that is under the DROID gripper's {RATED_OPENING * 1000:.0f} mm opening with "
        f"{GRASP_CLEARANCE * 1000:.0f} mm to spare on each side (yes), under it (tight) or not (no; a thin part such "
        "as a handle or rim may still be graspable)"
    )


def shape_counts_text(catalog: Catalog) -> str:
    """How many objects have each shape kind, e.g. '41 scanned, 35 modelled, 223 primitive'."""
    counts = {kind: 0 for kind in SHAPE_KINDS}
    for entry in catalog.objects.values():
        counts[entry.shape] += 1
    return ", ".join(f"{count} {kind}" for kind, count in counts.items())
