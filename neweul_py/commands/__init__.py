"""Sub-commands of the ``neweul`` CLI, one module each (see :mod:`neweul_py.cli`).

Building the parser imports no symbolic layer (sympy): command modules import
:mod:`neweul_py.api` (which pulls in ``codegen``) only when they run on a description file.
"""

#: Forms of the equations offered by ``--form``; the same as :data:`neweul_py.api.FORMS` (kept
#: here so that registering the sub-commands needs no symbolic layer; a test checks they agree).
FORMS: tuple[str, ...] = ("auto", "closed", "recursive")
