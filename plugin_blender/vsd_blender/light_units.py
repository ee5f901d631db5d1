# What Blender 4.5+ adds to a light's Power/Strength and Color, so vsd gets the light Cycles
# renders (issue 28, finding 7). Measured with Cycles 4.5 (a diffuse plane under each light,
# 256 spp; docs/blender-addon.md "Lights"):
# * Exposure: power x 2^exposure.
# * Normalize off: the power is not divided by the light's area, i.e. x 4 pi r^2 for a point
#   or spot light of radius r (measured 0.1257 at r = 0.1, 0.5027 at 0.2, pi at 0.5), and
#   x pi sin^2(angle/2) for a sun (0.007847 at angle 0.1).
# * Temperature: the colour is multiplied by the blackbody colour of that temperature,
#   scaled to luminance 1 (Rec.709 Y of Cycles' factor was 1.000 from 2000 K to 12000 K).
# The blackbody colour: Planck's law weighted by the CIE 1931 colour matching functions in
# the analytic multi-lobe form of Wyman, Sloan and Shirley (JCGT 2013), to CIE XYZ, then
# linear Rec.709. Within 1.3% of Cycles 4.5 per channel from 3000 K to 12000 K; at 2000 K
# blue is 0.019 against 0.022 (a tiny absolute part of that light). Python only, no bpy:
# tests/blender_addon/test_versions.py checks it against the version's own Cycles.
import math

# CIE XYZ -> linear Rec.709 (D65), IEC 61966-2-1.
XYZ_TO_REC709 = ((3.2404542, -1.5371385, -0.4985314),
                 (-0.9692660, 1.8760108, 0.0415560),
                 (0.0556434, -0.2040259, 1.0572252))

# (weight, mean nm, sigma below the mean, sigma above) per lobe, for x, y and z.
_LOBES = (((1.056, 599.8, 37.9, 31.0), (0.362, 442.0, 16.0, 26.7), (-0.065, 501.1, 20.4, 26.2)),
          ((0.821, 568.8, 46.9, 40.5), (0.286, 530.9, 16.3, 31.1)),
          ((1.217, 437.0, 11.8, 36.0), (0.681, 459.0, 26.0, 13.8)))

_C2 = 1.4387769e-2  # second radiation constant h c / k, m K


def _cmf(lobes, nm):
    out = 0.0
    for w, mu, s_lo, s_hi in lobes:
        s = s_lo if nm < mu else s_hi
        out += w * math.exp(-0.5 * ((nm - mu) / s) ** 2)
    return out


def blackbody_rec709(kelvin):
    """Linear Rec.709 colour of a blackbody at `kelvin`, luminance (Y) 1."""
    t = min(max(float(kelvin), 800.0), 40000.0)
    xyz = [0.0, 0.0, 0.0]
    for nm in range(360, 831):
        m = nm * 1e-9
        radiance = 1.0 / (m ** 5 * math.expm1(_C2 / (m * t)))
        for i in range(3):
            xyz[i] += radiance * _cmf(_LOBES[i], nm)
    xyz = [v / xyz[1] for v in xyz]
    return [sum(XYZ_TO_REC709[r][c] * xyz[c] for c in range(3)) for r in range(3)]


def intensity_factor(light):
    """Exposure and (with Normalize off) the light's area, as one factor on its power or
    strength; 1 for Blenders before 4.5, which have neither."""
    f = 2.0 ** float(getattr(light, "exposure", 0.0))
    if not getattr(light, "normalize", True):
        if light.type == "SUN":
            f *= math.pi * math.sin(min(max(light.angle, 0.0), math.pi) / 2.0) ** 2
        elif light.type in ("POINT", "SPOT"):
            r = max(light.shadow_soft_size, 0.0)
            f *= 4.0 * math.pi * r * r
    return f


def colour_factor(light):
    """The blackbody factor on the light's colour (use_temperature), or None."""
    if getattr(light, "use_temperature", False):
        return blackbody_rec709(light.temperature)
    return None
