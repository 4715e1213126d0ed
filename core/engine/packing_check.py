"""A packing held against the layout table (`layout`): every slot packed once, by the
function the table names, with its dtype and size (`EngineData` runs it on every model it
packs; a problem is a bug of the packing, raised as `layout.LayoutError`)."""

from .layout import BY_NAME


def check(packed, counts):
    """The problems of a packing against the table, as a list of messages (empty: none).

    packed : {packing function name: {slot name: array}}, what each `packing` function
    returned; counts : {name: int}, the model's counts the sizes are written in."""
    problems = []
    seen = {}
    for packer, arrays in packed.items():
        for name, array in arrays.items():
            slot = BY_NAME.get(name)
            if slot is None:
                problems.append(f"{packer} packed {name!r}, which is no slot of the layout")
                continue
            if name in seen:
                problems.append(f"slot {name!r} packed by {seen[name]} and by {packer}")
            seen[name] = packer
            if slot.packer != packer:
                problems.append(f"slot {name!r}: expected from {slot.packer}, packed by "
                                f"{packer}")
            if array.dtype.name != slot.dtype or array.ndim != 1:
                problems.append(f"slot {name!r}: expected a flat {slot.dtype} array, got "
                                f"{array.dtype.name} of shape {array.shape}")
            if slot.size != "-":
                size = eval(slot.size, {"__builtins__": {}}, counts)  # noqa: S307 (our table)
                if array.size != size:
                    problems.append(f"slot {name!r}: expected {slot.size} = {size} entries, "
                                    f"got {array.size}")
    problems += [f"slot {name!r} declared (packed by {BY_NAME[name].packer}) and never packed"
                 for name in BY_NAME if name not in seen]
    return problems
