"""Parametric studies (paper §6–7): the plan and multiresolution chains (``plan``), running
them serially or on Dask (``runner``), the resumable store on disk (``store``) and the
tables, figures and HTML report (``report``).

May import every lower room (``model``, ``latin``, ``io``, ``decomposition``, …); only
``multilatin.cli`` and the package's top level import this room.
"""
