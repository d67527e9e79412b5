"""An independent truth simulator of electromechanical drive axes (shares no code with ``vsa_gym``).

Written from textbook physics to make measured records that ``vsa-gym identify`` has to explain
without having produced them:

* :mod:`tests.truthsim.plant` -- motor + amplifier + lossy mesh + (rigid | compliant | backlash)
  transmission + load with exact stiction, Stribeck, Dahl, viscous friction and a constant force;
* :mod:`tests.truthsim.integrate` -- event-located RK4 with zero-order-held inputs, the quantising,
  noisy, possibly mis-scaled / offset / delayed encoder, and the sampled PD ("pd_cascade") loop;
* :mod:`tests.truthsim.excitation` -- multisine, chirp, steps, sines and point-to-point moves;
* :mod:`tests.truthsim.scenarios` -- ``draw_case(seed, effects)``, ``simulate_case``, ``write_case``;
* :mod:`tests.truthsim.records` -- the CSV, the user's sidecar and the separate ``<stem>.truth.json``.

Used by ``tests/truthsim/test_truthsim.py`` and ``python -m benchmarks.identify_truth``.
"""
