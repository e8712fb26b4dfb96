"""001's reverse-engineering chain: digitised sections -> rational surface -> IGES -> finishing.

- `sections`: digitised points read and grouped into cross-sections.
- `section_fit`: compatible rational fits of all sections (001 §2 on a family).
- `skinning`: skinned surface and C0/C1 patch merging (001 eq. 15, 17–18).
- `evaluation`: rational surface points, normals, closest points (001 eq. 13, 16).
- `iges`: IGES 5.3 entities 128 and 126, written and read.
- `toolpath`: ball-end finishing passes written as G06.2 groups.

May import: ipo.errors, ipo.nurbs, ipo.fit, numpy, numba.
"""
