"""The generic drive: a motor, its amplifier and a load on one axis (EMPS, CED, the truth simulator's records)."""

from vsa_gym.devices.spec import DeviceSpec, RecordSchema

DEVICE = DeviceSpec(
    name="drive",
    description="generic electromechanical drive: motor, amplifier, transmission, load (one axis)",
    record=RecordSchema(
        inputs={
            "voltage": ("V",),  # amplifier command, drive force = k_u * voltage
            "current": ("A",),  # current command of a current-mode amplifier, force = k_u * current
            "force": ("N", "N m"),  # motor force / torque at the load, given directly
            "external_force": ("N", "N m"),
            "feedforward": ("V", "A", "N", "N m"),  # added to the controller output (closed loop)
            "reference": ("m", "rad"),  # position reference of a closed loop
        },
        outputs={
            "position": ("m", "rad"),
            "velocity": ("m/s", "rad/s"),
            "speed_abs": ("m/s", "rad/s", "au"),  # rectified speed (a sensor blind to the sign)
            "force": ("N", "N m"),  # transmitted force / torque
            "controller_output": ("V", "A", "N", "N m"),
        },
        needs=frozenset({"voltage", "current", "force", "reference"}),
        needs_message="drive record needs a drive input: voltage, current, force or a closed-loop reference",
        params="vsa_gym.devices.drive.model:PNAMES",
        renamed={"x_c": "sticks, 1 for friction that sticks, 0 for one that creeps (x_c was a stick travel)"},
    ),
    adapter="vsa_gym.devices.drive.adapter:DriveAdapter",
    effects="vsa_gym.devices.drive.effects:LIBRARY",
)
