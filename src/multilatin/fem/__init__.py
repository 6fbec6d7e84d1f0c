"""Finite elements, the lowest room: meshes (structured Q4 rectangles and unstructured
Q4/T3), plane elasticity (Hooke matrices, stiffness, stresses), level sets and their cut cells,
and the X-FEM (Heaviside-enriched) stiffness of cut cells.

May import: ``multilatin.errors`` only. Knows nothing of substructures or interfaces.
"""
