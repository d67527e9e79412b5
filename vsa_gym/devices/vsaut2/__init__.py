"""The vsaUT-II variable stiffness actuator (Groothuis et al.; ``shared/papers/vsaut2-paper.md``)."""

from vsa_gym.devices.spec import DeviceSpec, EnvEntry, RecordSchema

DEVICE = DeviceSpec(
    name="vsaut2",
    description="vsaUT-II variable stiffness actuator (pivot and frame motors, lever with springs, belt)",
    record=RecordSchema(
        inputs={
            "voltage_pivot": ("V",),
            "voltage_frame": ("V",),
            "current_frame": ("A",),  # current-mode amplifier on the frame motor
            "external_torque": ("N m",),
        },
        outputs={
            "r": ("rad",),  # output link angle
            "q2": ("rad",),  # frame angle
            "phi": ("rad",),  # deflection r - q2
            "tau_out": ("N m",),  # elastic torque on the output
            "i2": ("A",),  # frame motor current
        },
        needs=frozenset({"voltage_pivot", "voltage_frame", "current_frame", "external_torque"}),
        needs_message="vsaut2 record needs a motor voltage / current or an external torque input",
    ),
    adapter="vsa_gym.devices.vsaut2.adapter:Vsaut2Adapter",
    effects="vsa_gym.devices.vsaut2.effects:LIBRARY",
    recovery="vsa_gym.devices.vsaut2.synthetic:BENCH",
    envs=(
        EnvEntry("VsaUT2-PositionStiffness-v0", "vsa_gym.devices.vsaut2.env_position_stiffness:VsaUT2PositionStiffness",
                 2500),
        EnvEntry("VsaUT2-Throw-v0", "vsa_gym.devices.vsaut2.env_throw:VsaUT2Throw", 500),
    ),
    reproduce="vsa_gym.devices.vsaut2.reproduce",
    datasheet="vsa_gym.devices.vsaut2.datasheet",
)
