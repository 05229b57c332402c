"""Bundled model files: each defines ``mechanism(**params) -> scenarios.MechanismSetup`` and runs
with ``nrrncf run <name>`` (``scenarios.mechanism_file``).

- ``slider_crank``: the flexible slider-crank of Escalona, Hussien & Shabana (1998), a rigid
  crank driven at constant speed, a flexible connecting rod (full ANCF, NR-RNCF or rigid) and a
  slider on a prismatic joint.
- ``rotor``: a rigid hub on a hinge with three of the paper's beams clamped to it, spun up by a
  motor torque (full ANCF or NR-RNCF beams).
- ``two_link_arm``: a flexible two-link arm on driven hinges with a payload, and the trajectory
  optimisation that removes its residual vibration (Adam on forward-mode gradients).
- ``fourbar``: the spatial four-bar of the validation set of Bauchau et al. (2016), square steel
  bars, a hinge tilted by 5° that only flexibility lets move, the crank driven at 0.6 rad/s.
- ``rotating_shaft``: the same set's shaft with an unbalanced disk, spun up through its first
  critical speed (a driven hinge, a cylindrical bearing, a welded rigid disk).
- ``princeton_beam``: the same set's static cantilever strip under a turned tip load
  (``nrrncf static``).
- ``lateral_buckling``: the same set's thin cantilever pushed up by a driven crank and a link
  past Prandtl's critical load, so that it buckles sideways (MBDyn's deck: C offset from the tip
  by 0.1 mm, the imperfection; full ANCF or NR-RNCF bars).
"""
