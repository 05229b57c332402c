"""Studies: what is done *with* the simulator, outside its core (bodies, elements, models,
reduction, integrator), which never imports this package.

- ``families``: parameterised reduced models, ``params -> model`` (fixed basis, or through the
  offline stage), the models that identification differentiates.
- ``identification``: measurements, the misfit, ``identify`` (Adam, then L-BFGS).
- ``control``: the spin-up profile with the least residual vibration (``optimal_spinup``).
- ``sweep``: batched, vmapped and device-sharded sweeps over (ωs, Ts, E).
- ``optimize``: the one L-BFGS / line-search driver shared by identification and control.

The public names are exported by the package (``nrrncf_jax.identify``, ``nrrncf_jax.spinup_sweep``,
...); the submodules are imported only when used.
"""
