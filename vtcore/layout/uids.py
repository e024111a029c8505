"""CySkin taxel UIDs, in one place: ``module_uid << 4 | sensor``.

A CySkin hub names each taxel by a 16-bit UID whose low 4 bits are the sensor
inside its module (1..10 or 1..11 for pressure, 0 for the temperature channel)
and whose high bits are the module's UID. Module UIDs start at 1; vtcore's
module ids start at 0, so ``module_uid = module_id + 1``, and a UID <= 0
(unknown) has module id -1. Layouts (:attr:`vtcore.layout.Layout.taxel_ids`),
the CySkin readers and writers, the CAN codec and the recordings all use these
functions rather than the bit arithmetic.
"""

from __future__ import annotations

import numpy as np

#: Bits of a UID that hold the sensor number inside its module.
SENSOR_BITS = 4
SENSOR_MASK = (1 << SENSOR_BITS) - 1


def cyskin_uids(module_ids, sensors) -> np.ndarray:
    """(N,) int64 UIDs of ``sensors`` (N,) int on modules ``module_ids`` (N,) int (0-based)."""
    module_ids = np.asarray(module_ids, dtype=np.int64)
    sensors = np.asarray(sensors, dtype=np.int64)
    return ((module_ids + 1) << SENSOR_BITS) | sensors


def cyskin_modules(uids) -> np.ndarray:
    """(N,) int64 0-based module ids of ``uids`` (N,) int; -1 where the UID is <= 0 (unknown)."""
    uids = np.asarray(uids, dtype=np.int64)
    return np.where(uids > 0, (uids >> SENSOR_BITS) - 1, -1)


def cyskin_sensors(uids) -> np.ndarray:
    """(N,) int64 sensor number inside its module of each of ``uids`` (0: temperature)."""
    return np.asarray(uids, dtype=np.int64) & SENSOR_MASK


def follows_cyskin(taxel_ids, module_ids) -> bool:
    """True when every taxel id is the CySkin UID of its module id (an empty layout too)."""
    taxel_ids = np.asarray(taxel_ids, dtype=np.int64)
    module_ids = np.asarray(module_ids, dtype=np.int64)
    return bool(np.all(module_ids >= 0) and np.array_equal(taxel_ids, cyskin_uids(module_ids,
                                                                                  cyskin_sensors(taxel_ids))))
