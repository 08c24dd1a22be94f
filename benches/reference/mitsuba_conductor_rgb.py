"""Mitsuba 3's named conductors in its RGB variants: the complex index `eta + i k` (relative
to vacuum) that `conductor` / `roughconductor` with `material="NAME"` use, as Mitsuba reduces
its spectral data to RGB. Prints the table of `src/scene/loader/mitsuba/conductors.rs`.

    pip install mitsuba numpy
    python3 benches/reference/mitsuba_conductor_rgb.py
"""

import mitsuba as mi

mi.set_variant("scalar_rgb")
mi.set_log_level(mi.LogLevel.Error)

NAMES = ["a-C", "Ag", "Al", "AlAs", "AlSb", "Au", "Be", "Cr", "CsI", "Cu", "Cu2O", "CuO", "d-C",
         "Hg", "HgTe", "Ir", "K", "Li", "MgO", "Mo", "Na_palik", "Nb", "Ni_palik", "Rh", "Se",
         "SiC", "SnTe", "Ta", "Te", "ThF4", "TiC", "TiN", "TiO2", "VC", "V_palik", "VN", "W"]
print(f"// Mitsuba {mi.__version__}")
for name in NAMES:
    params = mi.traverse(mi.load_dict({"type": "conductor", "material": name}))
    e, k = params["eta.value"], params["k.value"]
    print(f'    ("{name}", [{e[0]:.6}, {e[1]:.6}, {e[2]:.6}], [{k[0]:.6}, {k[1]:.6}, {k[2]:.6}]),')
