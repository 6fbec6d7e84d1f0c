"""What goes in and out as files: model files (``modelfile``: TOML, validated, split by
section), arithmetic expressions over parameters (``expressions``), output folders
(``files``), VTK/JSON/CSV results (``output``) and figures (``plots``).

May import: ``decomposition``, ``fem``, ``errors``, ``parameters``, ``limits``. Not the
solvers or the study engine.
"""
