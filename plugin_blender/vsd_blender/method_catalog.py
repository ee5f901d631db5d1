# The methods vsd renders, drawn from vsd's own registry, not a list kept here.
#
# vsd declares every method once (core/methods/registry.h): its name, label, a line of
# summary, what it can render (capabilities), which method a new scene and a new viewport
# use (roles), and its render.options as one table (key, type, range, default, choices, a
# line of doc, and "applies_when": the other options it depends on). `vsd methods --json`
# prints this catalog and the daemon's HELLO carries it as "method_catalog"
# (docs/protocol.md). From it this module builds the method menus, the warnings ("only
# these methods refract"), and one PropertyGroup per method, Scene.vsd_options.<method>.
# <key>, drawn in the Method Options panel (greyed out where an option does not apply);
# it sends the values that differ from the defaults and apply. A new method or option in
# vsd shows up here without a change to the add-on.
#
# Properties can only be registered on Blender's main thread, outside drawing; so the
# catalog is loaded when the add-on is enabled (from the vsd binary in the preferences or
# on PATH), when that preference changes, and by the Check Daemon button; a catalog that a
# render thread's HELLO brings is applied by a timer.
import json
import struct
import subprocess
import zlib

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty

_state = {"catalog": None, "text": None, "classes": [], "pending": None, "source": "", "items": [],
          "annotated": {}}

INT_LIMIT = 2 ** 31 - 1


def catalog():
    """[method, ...] as loaded (each {"name", "label", "summary", "capabilities", "roles",
    "options", "preview_options"}), or None."""
    return _state["catalog"]


def source():
    return _state["source"]


def _method(name):
    for m in _state["catalog"] or []:
        if m.get("name") == name:
            return m
    return None


def names():
    return [m["name"] for m in _state["catalog"] or []]


def label(name):
    m = _method(name)
    return m.get("label", name) if m else name


def has(name, capability):
    """Whether method `name` has the capability ("refraction", "scene_lights", ...)."""
    m = _method(name)
    return bool(m and m.get("capabilities", {}).get(capability))


def with_capability(capability):
    """The names of the methods that have it, in the catalog's order."""
    return [m["name"] for m in _state["catalog"] or [] if m.get("capabilities", {}).get(capability)]


def labels_with(capability):
    """'A and B', 'A, B and C': the labels of the methods with the capability, for warnings."""
    found = [label(n) for n in with_capability(capability)]
    return " and ".join(found) if len(found) < 3 else ", ".join(found[:-1]) + " and " + found[-1]


def preview_options(name):
    """The render.options vsd gives method `name` for a quick first look at a changed scene
    (its "preview_options": lbl's lighting on half the cells), {} when it has none or the
    catalog predates them."""
    m = _method(name)
    p = m.get("preview_options") if m else None
    return dict(p) if isinstance(p, dict) else {}


def default_for(role):
    """The method the catalog gives the role ("final_default", "viewport_default"), else
    the first method, else "" (no catalog: the daemon's own default)."""
    for m in _state["catalog"] or []:
        if role in m.get("roles", []):
            return m["name"]
    return names()[0] if names() else ""


def default_with(capability, role):
    """The method with the capability that has the role, else the first with it, else ""."""
    can = with_capability(capability)
    for m in _state["catalog"] or []:
        if m["name"] in can and role in m.get("roles", []):
            return m["name"]
    return can[0] if can else ""


# ---- the method menus ----------------------------------------------------------------------
# A menu's items come from the catalog, so its EnumProperty has an items function; the
# choice is kept by name in a hidden string (Scene.vsd.method_name), so a saved file keeps
# its method whatever order or number of methods a later vsd has, and "" means the
# catalog's default for the menu's role.

def _number(name):
    # stable per name (an index would change when the registry does)
    return zlib.crc32(name.encode("utf-8")) & 0x7FFFFFFF


SEVERAL = "several_volumes"   # the capability of the methods that render several volumes


def viewport_fallback():
    """What the viewport shows instead of a chosen method that renders one volume: the
    catalog's viewport default when it renders several (an interactive method), else the
    first method that does; "" when none does."""
    return default_with(SEVERAL, "viewport_default")


def _volume_count(settings, context, final):
    """How many volumes the scene of Scene.vsd `settings` sends (mapping.count_volumes), 0
    when there is no context to tell."""
    try:
        vl = context.view_layer if context is not None else None
        if vl is None or settings is None:
            return 0
        from . import mapping
        return mapping.count_volumes(settings.id_data, vl, final)
    except Exception:
        return 0


def _annotated(settings, context, final):
    """The menu's items; with several volumes in the scene, a method that renders one is
    marked so in its label and tooltip (Blender's enum items cannot be greyed out)."""
    base = _state["items"]
    n = _volume_count(settings, context, final)
    if n <= 1 or _state["catalog"] is None:
        return base
    key = (final, n)
    items = _state["annotated"].get(key)
    if items is None:
        fallback = viewport_fallback()
        items = []
        for name, lab, desc, num in base:
            if name and not has(name, SEVERAL):
                lab += " (one volume)"
                if final:
                    note = "Renders one volume: F12 refuses this scene's %d volumes" % n
                else:
                    note = ("Renders one volume: the viewport shows %s for this scene's %d volumes"
                            % (label(fallback), n) if fallback else "Renders one volume")
                desc = note + ". " + desc
            items.append((name, lab, desc, num))
        # Blender needs the strings kept alive while the menu is shown: kept in _state
        _state["annotated"][key] = items
    return items


def menu_items(self, context):
    """Items of the F12 method menu (self: Scene.vsd, None outside Blender's UI)."""
    return _annotated(self, context, True)


def viewport_menu_items(self, context):
    """Items of the viewport's method menu."""
    return _annotated(self, context, False)


def _rebuild_items():
    items = [(m["name"], m.get("label", m["name"]), m.get("summary", ""), _number(m["name"]))
             for m in _state["catalog"] or []]
    _state["items"] = items or [("", "(vsd not found)", "Set the vsd binary in the add-on preferences", 0)]
    _state["annotated"] = {}


def chosen(stored, role):
    """The method a menu shows: the stored name while the catalog has it, else the role's
    default."""
    return stored if stored and (_state["catalog"] is None or _method(stored)) else default_for(role)


def chosen_for(settings, viewport=False):
    """The method a render with Scene.vsd `settings` uses: the menu's choice, else vsd's
    default for it ("" when no catalog is loaded yet: the daemon then uses its own)."""
    if viewport:
        return chosen(settings.viewport_method_name, "viewport_default")
    return chosen(settings.method_name, "final_default")


def menu_get(stored, role):
    name = chosen(stored, role)
    return _number(name) if name else 0


def menu_set(value):
    """The name of the menu item numbered value ("" when none is)."""
    for m in _state["catalog"] or []:
        if _number(m["name"]) == value:
            return m["name"]
    return ""


# ---- the option panels -----------------------------------------------------------------------

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


def apply(cat, source=""):
    """Take catalog cat ([method, ...]) and register the option groups for it; a catalog
    equal to the loaded one changes nothing, so the values the user set stay."""
    if not isinstance(cat, list) or not all(isinstance(m, dict) and "name" in m for m in cat):
        return False
    text = json.dumps(cat, sort_keys=True)
    if text == _state["text"]:
        return True
    _unregister_classes()
    per_method = {}
    for m in cat:
        ann = {}
        for row in m.get("options", []):
            p = _prop_for(row)
            if p is not None:
                ann[row["key"]] = p
        cls = type("VSDOptions_" + m["name"], (bpy.types.PropertyGroup,), {"__annotations__": ann})
        bpy.utils.register_class(cls)
        _state["classes"].append(cls)
        per_method[m["name"]] = PointerProperty(type=cls)
    holder = type("VSDMethodOptions", (bpy.types.PropertyGroup,), {"__annotations__": per_method})
    bpy.utils.register_class(holder)
    _state["classes"].append(holder)
    bpy.types.Scene.vsd_options = PointerProperty(type=holder)
    _state["catalog"], _state["text"], _state["source"] = cat, text, source
    _rebuild_items()
    return True


def load_from_binary(path):
    """The catalog from `vsd methods --json`; False (and the catalog unchanged) when it fails."""
    try:
        out = subprocess.run([path, "methods", "--json"], capture_output=True, timeout=20, check=True)
        return apply(json.loads(out.stdout.decode("utf-8")), "vsd methods --json (%s)" % path)
    except (OSError, ValueError, subprocess.SubprocessError):
        return False


def _apply_pending():
    cat, _state["pending"] = _state["pending"], None
    if cat is not None:
        apply(cat, "the daemon's HELLO")
    return None


def from_hello(server, main_thread):
    """The catalog a HELLO brought: applied now on the main thread, else by a timer."""
    cat = (server or {}).get("method_catalog")
    if not isinstance(cat, list):
        return
    if main_thread:
        apply(cat, "the daemon's HELLO")
    elif json.dumps(cat, sort_keys=True) != _state["text"]:
        _state["pending"] = cat
        bpy.app.timers.register(_apply_pending, first_interval=0.0)


def rows(method):
    m = _method(method)
    return m.get("options", []) if m else []


def _group(scene, method):
    holder = getattr(scene, "vsd_options", None)
    return getattr(holder, method, None) if holder is not None else None


def _row_value(group, row):
    v = getattr(group, row["key"])
    return int(v) if row["type"] == "int" else (float(v) if row["type"] == "number" else v)


def applies(group, method, row):
    """Whether the option means something with the other options' values (its
    "applies_when" rule): vsd refuses an option set where it does not."""
    by_key = {r["key"]: r for r in rows(method)}
    for cond in row.get("applies_when", []):
        other = by_key.get(cond.get("key"))
        if other is None:
            continue
        value = _row_value(group, other)
        if "equals" in cond and value != cond["equals"]:
            return False
        if "differs" in cond and value == cond["differs"]:
            return False
    return True


def draw(layout, scene, method):
    """The method's options as panel rows (greyed out where they do not apply), or a line
    saying where the catalog comes from."""
    group = _group(scene, method)
    if _state["catalog"] is None or group is None:
        layout.label(text="Options appear once vsd is found (Check Daemon)", icon="INFO")
        return
    if not rows(method):
        layout.label(text="%s has no options" % label(method))
        return
    for row in rows(method):
        line = layout.row()
        line.active = applies(group, method, row)
        line.prop(group, row["key"])


def _float32(x):
    return struct.unpack("<f", struct.pack("<f", x))[0]


def _differs(row, value):
    d = row["default"]
    if row["type"] == "number":
        # Blender keeps a FloatProperty in single precision: an untouched 0.15 reads back as
        # 0.15000000596, which is the default and must not be sent (it was, for every
        # default whose float32 rounding exceeded 1e-9: view_threshold's)
        try:
            return _float32(float(value)) != _float32(float(d))
        except OverflowError:   # beyond float32's range: no property holds it
            return abs(float(value) - float(d)) > 1e-9 * max(1.0, abs(float(d)))
    if row["type"] == "bool":
        return bool(value) != bool(d)
    return value != d


def values(scene, method):
    """{key: value} for the options set away from vsd's defaults that apply."""
    group = _group(scene, method)
    out = {}
    if group is None:
        return out
    for row in rows(method):
        v = _row_value(group, row)
        if _differs(row, v) and applies(group, method, row):
            out[row["key"]] = v
    return out


def register():
    _rebuild_items()


def unregister():
    _unregister_classes()
    _state.update(catalog=None, text=None, pending=None, source="", items=[], annotated={})
