# Method options drawn from vsd's own table, not a list kept here.
#
# vsd declares every method's render.options as one table (key, type, range, default,
# choices, a line of doc): `vsd methods --json` prints it and the daemon's HELLO carries it
# as "method_options" (docs/protocol.md). From it this module registers one PropertyGroup
# per method, Scene.vsd_options.<method>.<key>, with the table's type, range, default and
# doc, draws them in the Method Options panel, and sends the values that differ from the
# defaults. A new method or option in vsd shows up here without a change to the add-on.
#
# Properties can only be registered on Blender's main thread, outside drawing; so the
# table is loaded when the add-on is enabled (from the vsd binary in the preferences or
# on PATH), when that preference changes, and by the Check Daemon button; a table that a
# render thread's HELLO brings is applied by a timer.
import json
import subprocess

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty

_state = {"table": None, "text": None, "classes": [], "pending": None, "source": ""}

INT_LIMIT = 2 ** 31 - 1


def table():
    """{method: [row, ...]} as loaded, or None."""
    return _state["table"]


def source():
    return _state["source"]


def _prop_for(row):
    doc = row.get("doc", "")
    t = row["type"]
    if t == "int":
        lo = 0 if row.get("auto_zero") else int(row["min"])
        if row.get("auto_zero"):
            doc += " [0 = automatic]"
        return IntProperty(name=row["key"], description=doc, default=int(row["default"]),
                           min=max(lo, -INT_LIMIT), max=min(int(row["max"]), INT_LIMIT))
    if t == "number":
        kw = {}
        if row.get("unit") == "length":
            kw["unit"] = "LENGTH"
        if row.get("auto_zero"):
            doc += " [0 = automatic]"
        return FloatProperty(name=row["key"], description=doc, default=float(row["default"]),
                             min=float(row["min"]), max=min(float(row["max"]), 3.0e38), precision=4, **kw)
    if t == "bool":
        return BoolProperty(name=row["key"], description=doc, default=bool(row["default"]))
    if t == "choice":
        items = [(c, c, "") for c in row["choices"]]
        return EnumProperty(name=row["key"], description=doc, items=items, default=row["default"])
    return None


def _unregister_classes():
    if hasattr(bpy.types.Scene, "vsd_options"):
        del bpy.types.Scene.vsd_options
    for cls in reversed(_state["classes"]):
        try:
            bpy.utils.unregister_class(cls)
        except RuntimeError:
            pass
    _state["classes"] = []


def apply(tbl, source=""):
    """Register the property groups for table tbl ({method: [row, ...]}); a table equal to
    the loaded one changes nothing, so the values the user set stay."""
    if not isinstance(tbl, dict):
        return False
    text = json.dumps(tbl, sort_keys=True)
    if text == _state["text"]:
        return True
    _unregister_classes()
    per_method = {}
    for method, rows in sorted(tbl.items()):
        ann = {}
        for row in rows:
            p = _prop_for(row)
            if p is not None:
                ann[row["key"]] = p
        cls = type("VSDOptions_" + method, (bpy.types.PropertyGroup,), {"__annotations__": ann})
        bpy.utils.register_class(cls)
        _state["classes"].append(cls)
        per_method[method] = PointerProperty(type=cls)
    holder = type("VSDMethodOptions", (bpy.types.PropertyGroup,), {"__annotations__": per_method})
    bpy.utils.register_class(holder)
    _state["classes"].append(holder)
    bpy.types.Scene.vsd_options = PointerProperty(type=holder)
    _state["table"], _state["text"], _state["source"] = tbl, text, source
    return True


def load_from_binary(path):
    """The table from `vsd methods --json`; False (and the table unchanged) when it fails."""
    try:
        out = subprocess.run([path, "methods", "--json"], capture_output=True, timeout=20, check=True)
        return apply(json.loads(out.stdout.decode("utf-8")), "vsd methods --json (%s)" % path)
    except (OSError, ValueError, subprocess.SubprocessError):
        return False


def _apply_pending():
    tbl, _state["pending"] = _state["pending"], None
    if tbl is not None:
        apply(tbl, "the daemon's HELLO")
    return None


def from_hello(server, main_thread):
    """The table a HELLO brought: applied now on the main thread, else by a timer."""
    tbl = (server or {}).get("method_options")
    if not isinstance(tbl, dict):
        return
    if main_thread:
        apply(tbl, "the daemon's HELLO")
    elif json.dumps(tbl, sort_keys=True) != _state["text"]:
        _state["pending"] = tbl
        bpy.app.timers.register(_apply_pending, first_interval=0.0)


def rows(method):
    return (_state["table"] or {}).get(method, [])


def _group(scene, method):
    holder = getattr(scene, "vsd_options", None)
    return getattr(holder, method, None) if holder is not None else None


def draw(layout, scene, method):
    """The method's options as panel rows, or a line saying where the table comes from."""
    group = _group(scene, method)
    if _state["table"] is None or group is None:
        layout.label(text="Options appear once vsd is found (Check Daemon)", icon="INFO")
        return
    if not rows(method):
        layout.label(text="%s has no options" % method)
        return
    for row in rows(method):
        layout.prop(group, row["key"])


def _differs(row, value):
    d = row["default"]
    if row["type"] == "number":
        return abs(float(value) - float(d)) > 1e-9 * max(1.0, abs(float(d)))
    if row["type"] == "bool":
        return bool(value) != bool(d)
    return value != d


def values(scene, method):
    """{key: value} for the options set away from vsd's defaults."""
    group = _group(scene, method)
    out = {}
    if group is None:
        return out
    for row in rows(method):
        v = getattr(group, row["key"])
        if _differs(row, v):
            out[row["key"]] = int(v) if row["type"] == "int" else (float(v) if row["type"] == "number" else v)
    return out


def register():
    pass


def unregister():
    _unregister_classes()
    _state.update(table=None, text=None, pending=None, source="")
