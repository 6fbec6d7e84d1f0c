"""Independent reference solvers of the same discrete problems, for verification: the
monolithic assembly without decomposition (``monolithic``), semi-smooth Newton for frictional
contact (``contact_newton``), and conforming meshes with the holes cut out by gmsh
(``conforming``).

May import: ``decomposition``, ``fem``, ``io`` (the model file, to re-mesh a body),
``errors``. Never ``latin``: a reference that shared the solver's code would check nothing.
"""
