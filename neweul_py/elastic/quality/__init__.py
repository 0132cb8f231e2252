"""Quality of reduced bodies: FRF errors, eigenvalues, stability, rigid motion, statics.

* :mod:`~neweul_py.elastic.quality.measures` – FRFs of full and reduced models, relative
  errors, eigenvalue comparison, right-half-plane poles;
* :mod:`~neweul_py.elastic.quality.frf_sweep` – the fast frequency response of a full FE model
  (adaptive rational interpolation, checked);
* :mod:`~neweul_py.elastic.quality.rigid_motion` – rigid-body motion of an FE model and a basis;
* :mod:`~neweul_py.elastic.quality.static_equilibrium` – a working-point body tied to a rigid
  part, against its FE model.
"""
