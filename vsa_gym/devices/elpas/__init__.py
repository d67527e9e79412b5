"""The eLPAS variable-geometry active suspension (``shared/papers/elpas-paper.md``)."""

from vsa_gym.devices.spec import DeviceSpec, EnvEntry, RecordSchema

DEVICE = DeviceSpec(
    name="elpas",
    description="eLPAS variable-geometry active suspension (cone spring, arm drive; hydropulse rig, quarter car)",
    record=RecordSchema(
        inputs={
            "voltage": ("V",),
            "alpha": ("rad",),  # imposed wishbone angle (hydropulse rig)
            "force_reference": ("N",),  # closed-loop force reference
        },
        outputs={
            "force": ("N",),  # actuator force F_act
            "gamma": ("rad",),  # arm angle
            "current": ("A",),
            "voltage": ("V",),  # controller output of a closed loop
        },
        needs=frozenset({"alpha"}),
        needs_message="elpas rig record needs the imposed wishbone angle 'alpha' as an input",
    ),
    adapter="vsa_gym.devices.elpas.adapter:ElpasAdapter",
    effects="vsa_gym.devices.elpas.effects:LIBRARY",
    recovery="vsa_gym.devices.elpas.synthetic:BENCH",
    envs=(
        EnvEntry("ELPAS-ForceTracking-v0", "vsa_gym.devices.elpas.env_force_tracking:ElpasForceTracking", 5000),
        EnvEntry("ELPAS-QuarterCar-v0", "vsa_gym.devices.elpas.env_quarter_car:ElpasQuarterCar", 5000),
    ),
    reproduce="vsa_gym.devices.elpas.reproduce",
)
