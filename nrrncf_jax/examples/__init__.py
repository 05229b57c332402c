"""Bundled model files: each defines ``mechanism(**params) -> scenarios.MechanismSetup`` and runs
with ``nrrncf run <name>`` (``scenarios.mechanism_file``).

- ``slider_crank``: the flexible slider-crank of Escalona, Hussien & Shabana (1998), a rigid
  crank driven at constant speed, a flexible connecting rod (full ANCF, NR-RNCF or rigid) and a
  slider on a prismatic joint.
"""
