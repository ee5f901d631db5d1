# Settings (Scene.vsd), add-on preferences and the Render Properties panels.
import bpy
from bpy.props import (BoolProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty,
                       StringProperty)

from . import connection, mapping, method_catalog

# Where medium.ior / volume.ior_grid / medium.ior_from come from (mapping.map_ior).
IOR_SOURCES = [
    ("constant", "Constant", "One refractive index inside the medium (IOR, medium.ior), 1 outside"),
    ("grid", "Grid", "A grid of the volume file holds the refractive index n itself (volume.ior_grid)"),
    ("temperature", "Heat Haze from Temperature",
     "n from the temperature grid by Gladstone-Dale (medium.ior_from temperature): hot air has a "
     "lower index, so light bends above fire, as heat haze does. Only some methods refract: the "
     "panel says which"),
]
DEVICES = [("auto", "Auto", "CUDA when a GPU is present, else CPU"),
           ("cpu", "CPU", "CPU threads"), ("cuda", "CUDA", "NVIDIA GPU")]


def _tag_redraw(self, context):
    for area in getattr(context.screen, "areas", []) if context.screen else []:
        if area.type == "VIEW_3D":
            area.tag_redraw()


# The two method menus, from vsd's catalog (method_catalog.py); the choice is kept by name.
def _get_method(self):
    return method_catalog.menu_get(self.method_name, "final_default")


def _set_method(self, value):
    self.method_name = method_catalog.menu_set(value)


def _get_viewport_method(self):
    return method_catalog.menu_get(self.viewport_method_name, "viewport_default")


def _set_viewport_method(self, value):
    self.viewport_method_name = method_catalog.menu_set(value)


class VSDSceneSettings(bpy.types.PropertyGroup):
    method_name: StringProperty(name="Method Name", default="", options={"HIDDEN"},
                                description="The F12 method's name (empty: vsd's default)")
    method: EnumProperty(name="Method", items=method_catalog.menu_items, get=_get_method, set=_set_method,
                         description="vsd rendering method for F12 and animation renders")
    samples: IntProperty(name="Samples", default=64, min=1, max=1000000,
                         description="Samples per pixel (progressive methods)")
    seed: IntProperty(name="Seed", default=1, min=0, max=2147483647)
    device: EnumProperty(name="Device", items=DEVICES, default="auto")
    threads: IntProperty(name="Threads", default=0, min=0, max=4096,
                         description="CPU threads of the daemon for this job, 0 = all")
    ior_source: EnumProperty(name="Index Source", items=IOR_SOURCES, default="constant",
                             description="Where the refractive index comes from. Only the vsd "
                             "methods that refract use it (the panel says which). Blender "
                             "itself does not refract inside volumes")
    ior: FloatProperty(name="IOR", default=1.0, min=1.0, max=4.0,
                       description="Refractive index inside the medium (medium.ior), 1 outside: the vsd "
                       "methods that refract bend rays through it; Blender itself does not refract inside volumes")
    ior_grid: StringProperty(name="Index Grid", default="",
                             description="Grid of the volume file holding the refractive index n itself "
                             "(volume.ior_grid; 0 = background, n = 1; a value below 1 is an error)")
    ior_temperature_grid: StringProperty(name="Temperature Grid", default="temperature",
                                         description="Grid of Blender's normalised temperature "
                                         "(volume.ior_grid with medium.ior_from temperature); Blender's "
                                         "smoke and fire domains write it as 'temperature' in their VDB cache")
    options_json: StringProperty(name="Options", default="",
                                 description="More method options as a JSON object, e.g. "
                                 "{\"lights\": 64}; overrides the option fields")
    viewport_method_name: StringProperty(name="Viewport Method Name", default="", options={"HIDDEN"},
                                         description="The viewport method's name (empty: vsd's default)")
    viewport_method: EnumProperty(name="Viewport Method", items=method_catalog.viewport_menu_items,
                                  get=_get_viewport_method, set=_set_viewport_method,
                                  description="Method of the rendered viewport preview (vsd's default "
                                  "scatters more than once, so it is as bright as the final render)",
                                  update=_tag_redraw)
    viewport_samples: IntProperty(name="Viewport Samples", default=4, min=1, max=100000)
    viewport_resolution: IntProperty(name="Resolution", default=50, min=1, max=100,
                                     subtype="PERCENTAGE",
                                     description="Preview resolution, percent of the viewport's pixels "
                                     "(scaled up for display)")
    viewport_start_scale: IntProperty(name="Start Resolution", default=4, min=1, max=16,
                                      description="The preview first renders at 1/N of the "
                                      "viewport's resolution, then refines to full")


def _vsd_path_changed(self, context):
    load_options_table(self)


class VSDPreferences(bpy.types.AddonPreferences):
    bl_idname = __package__

    vsd_path: StringProperty(name="vsd Binary", subtype="FILE_PATH", default="",
                             description="Path of the `vsd` executable (empty: `vsd` on PATH)",
                             update=_vsd_path_changed)
    address: StringProperty(name="Daemon Address", default="",
                            description="Unix socket path, or HOST:PORT for TCP (empty: the "
                            "default socket $XDG_RUNTIME_DIR/vsd.sock)")
    token: StringProperty(name="Token", default="", subtype="PASSWORD",
                          description="TCP token (the daemon's --token-file contents)")
    auto_start: BoolProperty(name="Auto-start Daemon", default=True,
                             description="Start `vsd serve` when no daemon answers, and stop "
                             "it when Blender exits")

    def draw(self, context):
        col = self.layout.column()
        col.prop(self, "vsd_path")
        col.prop(self, "address")
        col.prop(self, "token")
        col.prop(self, "auto_start")
        row = col.row()
        row.operator("vsd.daemon_status", icon="FILE_REFRESH")
        row.label(text=connection.status["text"])


class VSD_OT_daemon_status(bpy.types.Operator):
    """Connect to the vsd daemon and show its version and cache use"""
    bl_idname = "vsd.daemon_status"
    bl_label = "Check Daemon"

    def execute(self, context):
        from .engine import conn_settings
        st = connection.refresh_status(conn_settings(context))
        self.report({"INFO"} if st["ok"] else {"WARNING"}, "vsd: " + st["text"])
        return {"FINISHED"}


class VSD_OT_stop_daemon(bpy.types.Operator):
    """Stop the daemon that Blender started"""
    bl_idname = "vsd.stop_daemon"
    bl_label = "Stop Daemon"

    @classmethod
    def poll(cls, context):
        return connection.daemon_started_here()

    def execute(self, context):
        connection.close_all()
        connection.stop_daemon()
        connection.status.update(text="stopped", ok=False)
        return {"FINISHED"}


def settings_column(panel, context):
    """(Scene.vsd, a column of the panel laid out as Blender's own render panels are)."""
    layout = panel.layout
    layout.use_property_split = True
    layout.use_property_decorate = False
    return context.scene.vsd, layout.column()


class VSDPanel:
    bl_space_type = "PROPERTIES"
    bl_region_type = "WINDOW"
    bl_context = "render"
    COMPAT_ENGINES = {"VSD"}

    @classmethod
    def poll(cls, context):
        return context.engine in cls.COMPAT_ENGINES


def _volume_data(context):
    """The Volume data whose grids the index grid is chosen from: the active object's if it
    is a volume, else the first volume object of the scene by name; None if there is none."""
    ob = getattr(context, "active_object", None)
    if ob is None or ob.type != "VOLUME":
        vols = sorted((o for o in context.scene.objects if o.type == "VOLUME"), key=lambda o: o.name)
        ob = vols[0] if vols else None
    return ob.data if ob is not None else None


def draw_ior(col, context, s):
    """The refractive index rows: the source, then IOR (Constant) or the grid's name, offered
    from the volume's grids (Grid, Heat Haze)."""
    col.prop(s, "ior_source")
    if s.ior_source == "constant":
        col.prop(s, "ior")
        refracts = s.ior != 1.0
    else:
        key = "ior_grid" if s.ior_source == "grid" else "ior_temperature_grid"
        vol = _volume_data(context)
        if vol is not None:
            try:
                vol.grids.load()   # as Blender's own Volume panel does in its draw()
            except Exception:
                pass
            # a name the volume's file lacks shows red (the render would fail on it)
            col.prop_search(s, key, vol, "grids", text="Grid")
        else:
            col.prop(s, key, text="Grid")
        refracts = True
    if refracts and _volume_count(context, True) > 1:
        col.label(text="Ignored: vsd refracts a scene of one volume only", icon="INFO")
    elif refracts and not method_catalog.has(method_catalog.chosen_for(s), "refraction"):
        col.label(text="Only %s refract" % method_catalog.labels_with("refraction"), icon="INFO")


def _volume_count(context, final):
    try:
        return mapping.count_volumes(context.scene, context.view_layer, final)
    except Exception:
        return 0


def draw_volume_count(col, context, s, viewport):
    """A line under a method menu when the scene's volumes are more than the method renders:
    F12 refuses them, the viewport shows the catalog's method that renders several. Returns
    the line drawn ("" if none)."""
    if method_catalog.catalog() is None:
        return ""
    n = _volume_count(context, not viewport)
    method = method_catalog.chosen_for(s, viewport)
    if n <= 1 or not method or method_catalog.has(method, method_catalog.SEVERAL):
        return ""
    can = ("%s render several" % method_catalog.labels_with(method_catalog.SEVERAL)
           if method_catalog.with_capability(method_catalog.SEVERAL) else "no method of this vsd renders several")
    if viewport:
        fallback = method_catalog.viewport_fallback()
        if fallback:
            text = ("%s renders one volume; showing %s for %d volumes"
                    % (method_catalog.label(method), method_catalog.label(fallback), n))
            col.label(text=text, icon="INFO")
            return text
    text = "%s renders one volume: F12 refuses these %d (%s)" % (method_catalog.label(method), n, can)
    col.label(text=text, icon="ERROR")
    return text


class RENDER_PT_vsd(VSDPanel, bpy.types.Panel):
    bl_label = "vsd"

    def draw(self, context):
        s, col = settings_column(self, context)
        col.prop(s, "method")
        draw_volume_count(col, context, s, viewport=False)
        method = method_catalog.chosen_for(s)
        if method_catalog.catalog() is not None and not method_catalog.has(method, "multiple_scattering"):
            col.label(text="Scatters light once: darker than Cycles (%s scatter more)"
                      % method_catalog.labels_with("multiple_scattering"), icon="INFO")
        col.prop(s, "device")
        col.prop(s, "samples")
        col.prop(s, "seed")
        col.prop(s, "threads")
        draw_ior(col, context, s)


class RENDER_PT_vsd_options(VSDPanel, bpy.types.Panel):
    bl_label = "Method Options"
    bl_parent_id = "RENDER_PT_vsd"

    def draw(self, context):
        s, col = settings_column(self, context)
        # one row per option of vsd's own table (vsd methods --json / HELLO)
        method_catalog.draw(col, context.scene, method_catalog.chosen_for(s))
        col.prop(s, "options_json")


class RENDER_PT_vsd_viewport(VSDPanel, bpy.types.Panel):
    bl_label = "Viewport"
    bl_parent_id = "RENDER_PT_vsd"

    def draw(self, context):
        s, col = settings_column(self, context)
        col.prop(s, "viewport_method", text="Method")
        shown = draw_volume_count(col, context, s, viewport=True)
        col.prop(s, "viewport_samples", text="Samples")
        col.prop(s, "viewport_resolution")
        col.prop(s, "viewport_start_scale")
        fps = connection.status.get("preview_fps")
        if fps:
            col.label(text="Preview: %.1f frames/s" % fps)
        lat = connection.status.get("preview_latency")
        if lat:
            col.label(text="Last update on screen %.2f s after the change" % lat)
        # the scene mapping's (and the daemon's) warnings for the preview, also drawn over it
        for w in connection.status.get("preview_warnings") or []:
            if w != "vsd: " + shown:   # the fallback's line, drawn under the menu already
                col.label(text=w, icon="ERROR")


class RENDER_PT_vsd_daemon(VSDPanel, bpy.types.Panel):
    bl_label = "Daemon"
    bl_parent_id = "RENDER_PT_vsd"

    def draw(self, context):
        layout = self.layout
        st = connection.status
        col = layout.column()
        col.label(text=st["text"], icon="CHECKMARK" if st["ok"] else "ERROR")
        row = col.row()
        row.operator("vsd.daemon_status", icon="FILE_REFRESH")
        row.operator("vsd.stop_daemon", icon="CANCEL")


# Blender's own panels (film, output, camera, material, world) that apply to vsd too.
_EXTRA_PANELS = ("RENDER_PT_format", "RENDER_PT_frame_range", "RENDER_PT_output",
                 "RENDER_PT_film", "RENDER_PT_color_management",
                 "EEVEE_MATERIAL_PT_context_material", "EEVEE_MATERIAL_PT_volume",
                 "EEVEE_WORLD_PT_surface", "DATA_PT_lens", "DATA_PT_camera",
                 "DATA_PT_volume_file", "DATA_PT_volume_grids", "DATA_PT_context_volume",
                 "VIEWLAYER_PT_layer")


def _compat_panels():
    out = []
    for p in bpy.types.Panel.__subclasses__():
        ce = getattr(p, "COMPAT_ENGINES", None)
        if ce is None or p.__name__.startswith(("RENDER_PT_vsd",)):
            continue
        if "BLENDER_RENDER" in ce or p.__name__ in _EXTRA_PANELS:
            out.append(p)
    return out


CLASSES = (VSDSceneSettings, VSDPreferences, VSD_OT_daemon_status, VSD_OT_stop_daemon,
           RENDER_PT_vsd, RENDER_PT_vsd_options, RENDER_PT_vsd_viewport, RENDER_PT_vsd_daemon)


def load_options_table(prefs):
    """The method catalog from the vsd binary (the preference, else PATH)."""
    try:
        path = connection.find_vsd(prefs.vsd_path if prefs else "")
    except Exception:
        return False
    return method_catalog.load_from_binary(path)


def _prefs():
    addon = bpy.context.preferences.addons.get(__package__)
    return addon.preferences if addon else None


def register():
    method_catalog.register()
    for c in CLASSES:
        bpy.utils.register_class(c)
    bpy.types.Scene.vsd = PointerProperty(type=VSDSceneSettings)
    load_options_table(_prefs())
    for p in _compat_panels():
        p.COMPAT_ENGINES.add("VSD")


def unregister():
    method_catalog.unregister()
    for p in _compat_panels():
        p.COMPAT_ENGINES.discard("VSD")
    del bpy.types.Scene.vsd
    for c in reversed(CLASSES):
        bpy.utils.unregister_class(c)
