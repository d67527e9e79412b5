"""The device registry (vsa_gym.devices): every declared reference resolves, and the CLI, the record checker,
the recovery bench and the environment registry all read their device lists from it."""

from __future__ import annotations

import gymnasium as gym
import pytest

import vsa_gym  # noqa: F401  (registers the ids)
from vsa_gym.devices import device, device_names, devices
from vsa_gym.devices.spec import load_ref
from vsa_gym.identify import recovery
from vsa_gym.identify.adapters import Adapter
from vsa_gym.identify.record import DEVICES as RECORD_DEVICES
from vsa_gym.identify.record import check_record


@pytest.mark.parametrize("name", device_names())
def test_every_declared_reference_resolves(name: str) -> None:
    d = device(name)
    assert d.record.inputs and d.record.outputs
    if d.adapter:
        assert issubclass(d.adapter_class(), Adapter)
    if d.effects:
        library = d.effect_library()
        names = [e.name for e in library]
        assert len(set(names)) == len(names), "an effect declared twice"
        for e in library:
            assert e.measurement or (e.params and e.enters and e.where), f"{name}.{e.name}: undocumented entry"
            for exp, ranges in e.synthetic.items():
                assert e.main in ranges, f"{name}.{e.name}: synthetic {exp} plants no main parameter"
                assert all(0 <= lo < hi for lo, hi in ranges.values()), f"{name}.{e.name}: bad range in {exp}"
    if d.recovery:
        bench = d.recovery_bench()
        assert bench.catalogue() and bench.negative_experiments()
        assert all(effect in bench.main for _, effect in bench.catalogue())
        library = {e.name: e for e in d.effect_library()}
        assert all(library[effect].synthetic for _, effect in bench.catalogue())  # planted ranges: the library's
    if d.reproduce:
        assert callable(load_ref(d.reproduce).run)
    if d.datasheet:
        mod = load_ref(d.datasheet)
        assert callable(mod.compute) and callable(mod.format_table)
    for env in d.envs:
        spec = gym.spec(f"vsa_gym/{env.name}")
        assert spec.max_episode_steps == env.max_episode_steps


def test_the_lists_come_from_the_registry() -> None:
    assert device_names() == RECORD_DEVICES
    assert tuple(d.name for d in devices() if d.recovery) == recovery.DEVICES
    from vsa_gym.cli import DATASHEETS, DEVICES

    assert tuple(d.name for d in devices() if d.reproduce) == DEVICES
    assert tuple(d.name for d in devices() if d.datasheet) == DATASHEETS
    with pytest.raises(ValueError, match="registered devices are drive, vsaut2, elpas"):
        device("nope")


def test_the_declared_input_rule_reaches_the_record_checker(tmp_path) -> None:
    import numpy as np
    import pandas as pd

    table = pd.DataFrame({"t": np.arange(5) * 1e-3, "f": np.zeros(5), "x": np.zeros(5)})
    meta = {"format": "vsa-gym/measured-data/1", "device": "elpas", "time": {"column": "t", "unit": "s"},
            "inputs": {"f": {"quantity": "force_reference", "unit": "N"}},
            "outputs": {"x": {"quantity": "force", "unit": "N", "sensor": "load cell"}}}
    problems = check_record(tmp_path / "r.csv", table=table, meta=meta)
    assert device("elpas").record.needs_message in problems


def test_adapters_name_only_library_effects(tmp_path) -> None:
    """Every effect an adapter offers on a record is its device library's entry (or a measurement effect)."""
    from vsa_gym.devices.drive.synthetic import make_drive_record
    from vsa_gym.devices.elpas.synthetic import make_elpas_record
    from vsa_gym.devices.vsaut2.synthetic import make_vsaut2_record

    for dev, (rec, _) in (("drive", make_drive_record(1, None)), ("vsaut2", make_vsaut2_record(1, effect=None)),
                          ("elpas", make_elpas_record(1, None, duration=0.3))):
        ad = device(dev).adapter_class()(rec)
        library = {e.name: e for e in device(dev).effect_library()}
        for name, spec in ad.effects.items():
            assert name in library, f"{dev}: {name} is not in the library"
            if not library[name].measurement:
                assert [p.name for p in spec.params] == [p.name for p in library[name].params]
