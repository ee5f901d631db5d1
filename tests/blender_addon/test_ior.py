# The refractive index's three sources in the add-on (issue 14), in real Blender:
#   blender --background --factory-startup --python-exit-code 1 \
#       --python tests/blender_addon/test_ior.py -- VSD SHARED_DATA TMP_DIR
#
# * Scene.vsd.ior_source (Constant / Grid / Heat Haze from Temperature), ior_grid and
#   ior_temperature_grid exist with their defaults and descriptions;
# * each source sends exactly the scene fields docs/scene-file.md defines: Constant only
#   medium.ior (what the add-on sent before the source existed); Grid volume.ior_grid,
#   medium.ior_from "none" and medium.ior 1 whatever the IOR field holds (the renderer
#   refuses ior_grid with medium.ior != 1); Heat Haze medium.ior_from "temperature" and
#   volume.ior_grid (default "temperature");
# * the vsd panel draws IOR for Constant and a grid field searched in the volume's grids for
#   the others, with a note when the method does not refract;
# * File > Export > vsd scene writes the same fields, and `vsd render` accepts the export;
# * F12 through the daemon: a heat-haze render of fire96 (it has Blender's "temperature"
#   grid) with `reference` at 16x9 works; a grid the file lacks, for either grid source, is a
#   Blender error naming it (the renderer's message).
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402
from common import check  # noqa: E402

import bpy  # noqa: E402

MEDIUM_KEYS = {"density", "albedo", "anisotropy", "emission_color", "emission_strength"}


def main():
    vsd, data, tmp = common.start_test()
    mapping = common.addon_module("mapping")
    ui = common.addon_module("ui")
    with common.addon_daemon(vsd, tmp) as d:
        scene, ob = common.build_scene(data, width=16, height=9)
        s = scene.vsd

        def sent():
            m = mapping.build_scene(bpy.context.evaluated_depsgraph_get())
            return m.scene, m.warnings

        def ior_fields(sc):
            """The refractive-index fields of a one-volume scene dict (absent ones left out),
            named as in the single-volume form (medium.ior, volume.ior_grid)."""
            out = {}
            vol = sc["volumes"][0]
            for sect, key in (("medium", "ior"), ("medium", "ior_from"), ("volume", "ior_grid")):
                where = vol["medium"] if sect == "medium" else vol
                if key in where:
                    out["%s.%s" % (sect, key)] = where[key]
            return out

        # --- the properties -----------------------------------------------------------------
        props = s.bl_rna.properties
        src = props.get("ior_source")
        check(src is not None and [i.identifier for i in src.enum_items] == ["constant", "grid", "temperature"]
              and s.ior_source == "constant", "ior_source: constant (default), grid, temperature")
        check(s.ior_grid == "" and s.ior_temperature_grid == "temperature",
              "grid names default to '' (Grid) and 'temperature' (Heat Haze)")
        haze = [i for i in src.enum_items if i.identifier == "temperature"][0]
        check("Gladstone-Dale" in haze.description and "methods refract" in haze.description
              and "fire" in haze.description, "Heat Haze says what it does (%s)" % haze.description)
        check("methods that refract" in src.description, "Index Source says only some methods refract")

        # --- Constant: what the add-on always sent ------------------------------------------
        sc, _ = sent()
        check(ior_fields(sc) == {"medium.ior": 1.0} and set(sc["volumes"][0]["medium"]) == MEDIUM_KEYS | {"ior"}
              and set(sc["volumes"][0]) == {"file", "grid", "matrix", "medium"},
              "Constant, IOR 1: medium.ior 1 only (%s)" % ior_fields(sc))
        s.ior = 1.25
        sc, warnings = sent()
        check(ior_fields(sc) == {"medium.ior": 1.25}, "Constant, IOR 1.25: medium.ior 1.25 only (%s)" % ior_fields(sc))
        # the warning names the method and those that refract, by the catalog's labels
        catalog = common.addon_module("method_catalog")
        want = "method %s ignores the refractive index: only %s refract" % (
            catalog.label("raymarch"), catalog.labels_with("refraction"))
        check(want in warnings and "Reference" in catalog.labels_with("refraction"),
              "a non-refracting method with IOR 1.25 is a warning (%s)" % warnings)

        # --- Grid ---------------------------------------------------------------------------
        s.ior_source = "grid"
        s.ior_grid = "density"
        sc, warnings = sent()
        check(ior_fields(sc) == {"medium.ior": 1.0, "medium.ior_from": "none", "volume.ior_grid": "density"},
              "Grid: ior_grid, ior_from none, medium.ior 1 although IOR is 1.25 (%s)" % ior_fields(sc))
        check(not any("not in the volume file" in w for w in warnings),
              "a grid of the file: no warning (%s)" % warnings)
        s.ior_grid = ""
        sc, warnings = sent()
        check(ior_fields(sc) == {"medium.ior": 1.0} and any("without a grid name" in w for w in warnings),
              "Grid without a name: n = 1 and a warning (%s, %s)" % (ior_fields(sc), warnings))
        s.ior_grid = "no_such_ior"
        sc, warnings = sent()
        check(sc["volumes"][0].get("ior_grid") == "no_such_ior" and
              any("'no_such_ior' is not in the volume file" in w and "density" in w for w in warnings),
              "Grid naming a missing grid: sent, with a warning listing the file's grids (%s)" % warnings)

        # --- Heat Haze from Temperature -----------------------------------------------------
        s.ior_source = "temperature"
        sc, _ = sent()
        check(ior_fields(sc) == {"medium.ior": 1.0, "medium.ior_from": "temperature", "volume.ior_grid": "temperature"},
              "Heat Haze: ior_from temperature, ior_grid temperature, medium.ior 1 (%s)" % ior_fields(sc))
        s.ior_temperature_grid = "heat"
        sc, _ = sent()
        check(ior_fields(sc) == {"medium.ior": 1.0, "medium.ior_from": "temperature", "volume.ior_grid": "heat"},
              "Heat Haze with grid 'heat' (%s)" % ior_fields(sc))
        s.ior_temperature_grid = ""
        sc, _ = sent()
        check(sc["volumes"][0].get("ior_grid") == "temperature", "Heat Haze with an empty grid name sends 'temperature'")
        s.ior_temperature_grid = "temperature"

        # --- the panel ----------------------------------------------------------------------
        bpy.context.view_layer.objects.active = ob
        for source, method, want in (("constant", "raymarch", [("prop", "ior_source"), ("prop", "ior"), "note"]),
                                     ("constant", "reference", [("prop", "ior_source"), ("prop", "ior")]),
                                     ("grid", "reference", [("prop", "ior_source"), "search ior_grid"]),
                                     ("temperature", "lbl", [("prop", "ior_source"), "search ior_temperature_grid"]),
                                     ("temperature", "shgrid", [("prop", "ior_source"),
                                                                "search ior_temperature_grid", "note"])):
            s.ior_source, s.method = source, method
            panel = common.FakePanel()
            ui.RENDER_PT_vsd.draw(panel, bpy.context)
            # (kind, key...) without the data each prop belongs to
            rows = [(r[0], r[2]) if r[0] == "prop" else ("search",) + r[2:] if r[0] == "search" else ("label", r[2])
                    for r in panel.layout.rows]
            start = rows.index(("prop", "ior_source")) if ("prop", "ior_source") in rows else len(rows)
            got = []
            for r in rows[start:]:
                if r[0] == "search":
                    got.append("search %s" % r[1] if r[2] == ob.data and r[3] == "grids" else "search elsewhere")
                elif r[0] == "label":
                    got.append("note" if "Reference and LBL" in (r[1] or "") else r)
                else:
                    got.append(r)
            check(got == want, "panel, %s with %s: %s (drew %s)" % (source, method, want, got))
        s.ior = 1.0

        # --- F12 and export on fire96: heat haze with reference ----------------------------
        ob.data.filepath = os.path.join(data, "fire96", "fluid_data_0024.vdb")
        ob.data.is_sequence = False
        grids = [g.name for g in ob.evaluated_get(bpy.context.evaluated_depsgraph_get()).data.grids]
        check("temperature" in grids, "fire96 has Blender's temperature grid (%s)" % grids)
        s.method, s.samples = "reference", 2
        s.ior_source = "temperature"
        sc, warnings = sent()
        check(ior_fields(sc) == {"medium.ior": 1.0, "medium.ior_from": "temperature", "volume.ior_grid": "temperature"}
              and not warnings, "fire96 heat haze with reference: the fields, no warning (%s)" % warnings)
        out = os.path.join(tmp, "haze.exr")
        err = common.run_blender_render(out)
        check(err is None, "F12 heat haze on fire96, reference 16x9 (%s)" % err)
        if err is None:
            img, w, h = common.read_exr(out)
            check((w, h) == (16, 9) and any(k.endswith("Combined.R") for k in img), "the heat-haze EXR came back")

        ex, r = common.export_and_render(vsd, tmp, "haze")
        check(ior_fields(ex) == ior_fields(sc), "the export carries the same fields (%s)" % ior_fields(ex))
        check(r.returncode == 0, "vsd render accepts the exported heat-haze scene (%s)" % r.stderr.strip())

        # --- a grid the file lacks: the renderer's error, naming it, reaches the user ------
        for source, key in (("grid", "ior_grid"), ("temperature", "ior_temperature_grid")):
            s.ior_source = source
            setattr(s, key, "no_such_%s" % source)
            err = common.run_blender_render()
            print("missing %s grid ->" % source, err)
            check(err is not None and "no_such_%s" % source in err and "vsd daemon" in err,
                  "%s naming a missing grid: a Blender error with the daemon's message naming it (%s)" % (source, err))
        s.ior_grid, s.ior_temperature_grid = "", "temperature"
        # a grid of the file that is not n (density < 1): the renderer refuses it, by name
        s.ior_source, s.ior_grid = "grid", "density"
        err = common.run_blender_render()
        print("density as n ->", err)
        check(err is not None and "density" in err and "vsd daemon" in err,
              "Grid 'density' (values below 1) is the renderer's error naming it (%s)" % err)
        # (and the test ends on a render that works: Blender 3.4 --python-exit-code exits 1
        # when the script's last operator call failed, even with its RuntimeError caught)
        s.ior_source, s.ior_grid = "constant", ""
        err = common.run_blender_render()
        check(err is None, "back to Constant: F12 renders again (%s)" % err)
    common.finish("blender_addon_ior")


main()
