"""Files of the elastic layer: FE models, SID, body files (versioned, no pickles).

* :mod:`~neweul_py.elastic.io.fe_files` – FE models (JSON manifest with Matrix Market /
  Harwell–Boeing files, or ``.npz``); :mod:`~neweul_py.elastic.io.working_point` – the optional
  static and loss groups of a working-point FE file;
* :mod:`~neweul_py.elastic.io.body_files` – reduced and parametric body files
  (``docs/reduced-body-format.md``);
* :mod:`~neweul_py.elastic.io.sid` – SID files (standard input data of flexible bodies);
* :mod:`~neweul_py.elastic.io.reader` – the elastic data of a description's ``elastic_bodies``;
* :mod:`~neweul_py.elastic.io.npz` – atomic ``.npz`` writes and checked reads.
"""

from .body_files import (
    load_parametric_body,
    load_reduced_body,
    save_parametric_body,
    save_reduced_body,
)
from .fe_files import read_fe_model, write_fe_model
from .sid import read_sid, write_sid

__all__ = ["load_parametric_body", "load_reduced_body", "read_fe_model", "read_sid",
           "save_parametric_body", "save_reduced_body", "write_fe_model", "write_sid"]
