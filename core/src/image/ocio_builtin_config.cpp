// vsd's own OpenColorIO config: the linear colour spaces Blender 4.x and 5.x offer (and sRGB),
// under Blender's names, for converting environment maps when the config in use lacks them:
// Blender 3.4's config (Debian's) names them otherwise ("Linear", "Linear ACEScg") and has
// no Rec.2020, and Blender 5.0's config is an OCIO 2.4 profile that Debian's OCIO 2.1 cannot
// read. Everything is OCIO's own: its built-in ACES transforms, and for Rec.2020 and DCI-P3
// D65 the published RGB -> CIE XYZ (D65) matrices of those standards (ITU-R BT.2020,
// SMPTE EG 432-1). Reference space: ACES2065-1. Checked against Blender 4.2's config in
// tests/test_env.c (within 5e-4).
#include "src/image/imageio_internal.h"

extern "C" const char vsd_ocio_builtin_config[] = R"ocio(
ocio_profile_version: 2

environment: {}
search_path: ""
strictparsing: true
luma: [0.2126, 0.7152, 0.0722]
name: vsd-builtin-linear
description: vsd's own linear colour spaces, under the names Blender 4.x and 5.x give them

roles:
  default: Linear Rec.709
  scene_linear: Linear Rec.709
  data: Non-Color
  aces_interchange: ACES2065-1
  cie_xyz_d65_interchange: Linear CIE-XYZ D65
  color_picking: sRGB

file_rules:
  - !<Rule> {name: Default, colorspace: default}

displays:
  sRGB:
    - !<View> {name: Standard, colorspace: sRGB}

active_displays: [sRGB]
active_views: [Standard]

colorspaces:
  - !<ColorSpace>
    name: ACES2065-1
    aliases: [aces2065_1, ACES - ACES2065-1, Linear ACES]
    description: ACES AP0 primaries, the reference space of this config
  - !<ColorSpace>
    name: ACEScg
    aliases: [Linear ACEScg, ACES - ACEScg]
    to_scene_reference: !<BuiltinTransform> {style: ACEScg_to_ACES2065-1}
  - !<ColorSpace>
    name: Linear Rec.709
    aliases: [Linear, Linear BT.709, linear srgb, Linear sRGB, lin_rec709]
    to_scene_reference: !<GroupTransform>
      children:
        - !<BuiltinTransform> {style: UTILITY - ACES-AP1_to_LINEAR-REC709_BFD, direction: inverse}
        - !<BuiltinTransform> {style: ACEScg_to_ACES2065-1}
  - !<ColorSpace>
    name: Linear Rec.2020
    aliases: [Linear BT.2020, lin_rec2020]
    to_scene_reference: !<GroupTransform>
      children:
        - !<MatrixTransform> {matrix: [0.6369580, 0.1446169, 0.1688810, 0, 0.2627002, 0.6779981, 0.0593017, 0, 0.0000000, 0.0280727, 1.0609851, 0, 0, 0, 0, 1]}
        - !<BuiltinTransform> {style: UTILITY - ACES-AP0_to_CIE-XYZ-D65_BFD, direction: inverse}
  - !<ColorSpace>
    name: Linear DCI-P3 D65
    aliases: [Linear P3-D65]
    to_scene_reference: !<GroupTransform>
      children:
        - !<MatrixTransform> {matrix: [0.4865709, 0.2656677, 0.1982173, 0, 0.2289746, 0.6917385, 0.0792869, 0, 0.0000000, 0.0451134, 1.0439444, 0, 0, 0, 0, 1]}
        - !<BuiltinTransform> {style: UTILITY - ACES-AP0_to_CIE-XYZ-D65_BFD, direction: inverse}
  - !<ColorSpace>
    name: Linear CIE-XYZ D65
    aliases: [XYZ, CIE-XYZ-D65]
    to_scene_reference: !<BuiltinTransform> {style: UTILITY - ACES-AP0_to_CIE-XYZ-D65_BFD, direction: inverse}
  - !<ColorSpace>
    name: sRGB
    to_scene_reference: !<GroupTransform>
      children:
        - !<ExponentWithLinearTransform> {gamma: 2.4, offset: 0.055}
        - !<BuiltinTransform> {style: UTILITY - ACES-AP1_to_LINEAR-REC709_BFD, direction: inverse}
        - !<BuiltinTransform> {style: ACEScg_to_ACES2065-1}
  - !<ColorSpace>
    name: Non-Color
    aliases: [Raw]
    isdata: true
)ocio";
