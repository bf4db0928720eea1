"""helixd.link.services.param_plan: what loading a parameter file would change, compared as
the autopilot stores the values (float32), and which changes wait for a reboot."""

from __future__ import annotations

import struct

from helixd.link.services.param_plan import ParamChange, plan_changes, reboot_needed, same_value


def _float32(value: float) -> float:
    return float(struct.unpack("<f", struct.pack("<f", value))[0])


def test_a_value_the_autopilot_stores_as_float32_is_the_same() -> None:
    assert _float32(0.1) != 0.1
    assert same_value(_float32(0.1), 0.1)
    assert same_value(_float32(123456.7), 123456.7)
    assert not same_value(1.0, 1.001)
    assert not same_value(0.0, 1e-3)  # near zero the tolerance is absolute (1e-6)


def test_the_plan_lists_changes_in_the_files_order_and_the_missing_names() -> None:
    wanted = {"SERVO1_FUNCTION": 0.0, "RCMAP_ROLL": 2.0, "NO_SUCH": 1.0, "FS_GCS_ENABLE": 1.0}
    current = {"SERVO1_FUNCTION": 73.0, "RCMAP_ROLL": 1.0, "NO_SUCH": None, "FS_GCS_ENABLE": 1.0}
    changes, missing = plan_changes(wanted, current)
    assert changes == [
        ParamChange("SERVO1_FUNCTION", 73.0, 0.0),
        ParamChange("RCMAP_ROLL", 1.0, 2.0),
    ]
    assert missing == ["NO_SUCH"]
    assert plan_changes({"GONE": 1.0}, {}) == ([], ["GONE"])  # not reported at all: missing


def test_a_change_read_at_boot_only_says_so() -> None:
    rcmap, servo = ParamChange("RCMAP_ROLL", 1.0, 2.0), ParamChange("SERVO1_FUNCTION", 73.0, 0.0)
    assert rcmap.after_reboot and not servo.after_reboot
    assert rcmap.line().endswith("(after a reboot)")
    assert servo.line() == f"{'SERVO1_FUNCTION':<18} {73.0:>10g} → 0"
    assert reboot_needed(["SERVO1_FUNCTION", "RCMAP_ROLL", "SCR_ENABLE"]) == [
        "RCMAP_ROLL",
        "SCR_ENABLE",
    ]
