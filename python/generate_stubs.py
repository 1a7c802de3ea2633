"""Writes the dsnake module's type stubs: python/dsnake.pyi.in with its marked line replaced by
field() and energy(), one typing overload per registered type, generated from the module's own
catalogue of the options' declarations (dsnake._dsnake._catalogue(), from each plug-in's
visit()): its keys as keyword-only arguments with their Python types, and its key table (type,
unit, default, range, help) as the overload's docstring.

Usage: generate_stubs.py TEMPLATE OUTPUT (with the built package dsnake on sys.path).
"""
import keyword
import sys

import dsnake._dsnake as module

MARK = "# @GENERATED: field() and energy()\n"


def python_type(schema):
    """The Python annotation of a key from its JSON Schema."""
    if "enum" in schema:
        return "Literal[" + ", ".join(repr(v) for v in schema["enum"]) + "]"
    kind = schema.get("type")
    if kind == "array":
        items = python_type(schema.get("items", {}))
        return f"Sequence[{items}]"
    return {"number": "float", "integer": "int", "boolean": "bool", "string": "str",
            "object": "Mapping[str, Any]"}.get(kind, "Any")


def key_line(key):
    """One key as the documentation's table has it: name (type, unit) = default, range: help."""
    unit = ", " + key["unit"] if key["unit"] else ""
    default = " = " + key["default"] if key["default"] else ""
    rng = ", " + key["range"] if key["range"] else ""
    return f"{key['name']} ({key['type']}{unit}){default}{rng}: {key['help']}"


def docstring(entry, indent):
    dims = " and ".join(f"{d}D" for d in entry["dimensions"])
    lines = [f"{entry['name']} ({dims}): {entry['summary']}"]
    if entry["keys"]:
        lines.append("")
        lines += [key_line(k) for k in entry["keys"]]
    text = "\n".join(indent + line if line else "" for line in lines).replace("\\", "\\\\").replace('"""', '\\"\\"\\"')
    return f'{indent}"""{text.lstrip()}\n{indent}"""'


def keyword_arguments(entry, reserved):
    """The keys that can be keyword arguments, annotated; a key that is no Python identifier, or
    that names one of the function's own arguments, cannot be, and stops the build."""
    args = []
    for name, schema in entry["schema"].items():
        if not name.isidentifier() or keyword.iskeyword(name) or name in reserved:
            sys.exit(f"generate_stubs.py: {entry['name']}'s key {name!r} cannot be a keyword argument")
        args.append(f"{name}: {python_type(schema)} = ...")
    return args


def overloads(kind, entries, head, default_type, returns):
    """One @overload per type; `head` formats the arguments before the keys ({type} is the type's
    Literal, with ' = ...' for the default type)."""
    out = []
    for entry in entries:
        literal = f'Literal["{entry["name"]}"]' + (" = ..." if entry["name"] == default_type else "")
        reserved = {a.split(":")[0] for a in head}
        args = [a.format(type=literal) for a in head] + ["*"] + keyword_arguments(entry, reserved)
        if args[-1] == "*":
            args.pop()
        out.append("@overload\n"
                   f"def {kind}(" + ", ".join(args) + f") -> {returns}:\n" + docstring(entry, "    ") + "\n")
    return out


def generated(catalogue):
    fields, energies = catalogue["field"], catalogue["energy"]
    text = ["FieldType = Literal[" + ", ".join(f'"{e["name"]}"' for e in fields) + "]\n",
            "EnergyType = Literal[" + ", ".join(f'"{e["name"]}"' for e in energies) + "]\n\n"]
    text += overloads("field", fields, ["image: Image", "type: {type}"], "gvf", "npt.NDArray[np.float32]")
    text += overloads("energy", energies,
                      ["type: {type}", "template: Template", "image: Optional[Image] = None",
                       "field: Optional[Mapping[str, Any]] = None", "reference: Optional[Image] = None"],
                      None, "Energy")
    return "\n".join(text)


def main(template, output):
    with open(template, encoding="utf-8") as f:
        text = f.read()
    if text.count(MARK) != 1:
        sys.exit(f"generate_stubs.py: {template}: the line {MARK.strip()!r} must occur once")
    text = text.replace(MARK, generated(module._catalogue()))
    with open(output, "w", encoding="utf-8") as f:
        f.write(text)


if __name__ == "__main__":
    main(*sys.argv[1:])
