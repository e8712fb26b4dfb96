"""ipo — the interpolator stage: motion entities (ipr) in, per-period axis increments out.

Rooms, lowest first; a room imports only rooms listed above it (and ipr, numpy, numba),
never machine/:

| room | what lives there | papers |
|---|---|---|
| `ipo.config` | the machine file (TOML -> MachineConfig); `ipo/machine.toml` is the documented default; `ipo.config_values` its ranges and value checks; `ipo.grbl_settings` grbl's `$$` for the grbl twin; `ipo.linuxcnc_ini` a LinuxCNC INI file for the LinuxCNC twin | — |
| `ipo.roughness` | 002's surface-roughness model of ball-end finishing (read by the machine-file check and the feed limiter) | 002 eq. 1–6 |
| `ipo.contracts` | what every stage shares: the stepper contract (`Steps`) and the period stream (`PeriodBatch`, `LIMIT_*`) | 000 §2.2 |
| `ipo.segments` | the distance of a point from a segment, one compiled kernel for the rooms that measure deviations from polylines | — |
| `ipo.numpy_kernels` | numpy's linspace and interp as compiled kernels, to the bit (compiled code that picks the same parameters as a numpy path) | — |
| `ipo.nurbs` | the NURBS kernel: vectorised evaluation, the compiled per-period form, sub-curves | 000 eq. 1–4 |
| `ipo.interp` | constant-chord interpolation: recursive, Taylor, constant du, line/arc steppers, reference word and pulse, the chord study | 000 eq. 7–16, 002 eq. 7 |
| `ipo.feed` | the feed stage: pieces and corner blends, samples, limits (002's roughness limiter), look-ahead, S-curve, period output, the planner; the controller twins beside it (`grbl_twin/`, `linuxcnc_twin/`) and the registry that picks one (`profiles`) | 002 eq. 1–6 |
| `ipo.fit` | G01 runs -> rational B-spline G06.2 groups within a tolerance, and `vcnc fit`'s program rewriting | 001 eq. 1–11 |
| `ipo.surface` | digitised sections -> skinned rational surface -> IGES -> ball-end finishing passes | 001 eq. 12–18 |

Public entry points: `ipo.feed.planner.plan_periods` (entities -> PeriodBatch stream and
events; `ipo.feed.profiles.plan_function` gives a planner profile's, e.g. the grbl twin's), `ipo.interp.steppers.make_stepper`, `ipo.interp.chord_study.study`,
`ipo.fit.convert.convert_text`, `ipo.surface.section_fit.fit_sections`,
`ipo.surface.skinning.skin_patches`, `ipo.surface.iges`, `ipo.surface.toolpath.plan_passes`,
`ipo.config.load_config`. Nothing else is imported here, so that `import ipo.config` stays
cheap; `ipo.kernel_cache` first points numba's cache at a directory keyed by the kernels' source
(machine/ imports ipo before any kernel of its own).
"""
from ipo.kernel_cache import spare_scipy_linalg, use_source_keyed_cache

use_source_keyed_cache()
spare_scipy_linalg()
