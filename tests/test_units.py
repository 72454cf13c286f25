"""model.units: rpm -> rad/s gives one value whatever form the number takes
(the plain-number path skips NumPy's dispatch; it must not change a bit)."""
import math

import numpy as np

from fullspeed.model.units import RPM_TO_RAD_S, rad_s_to_rpm, rpm_to_rad_s


def test_rpm_to_rad_s_same_value_for_every_form_of_a_number():
    for n in (0, 1, -3000, 3000, 1e-3, 123.456):
        want = float(n) * (2.0 * math.pi / 60.0)
        for form in (n, float(n), np.float64(n), np.array(n), np.int64(round(n)) if float(n).is_integer() else n):
            got = rpm_to_rad_s(form)
            assert isinstance(got, float)
            assert got == want, (form, got, want)


def test_rpm_to_rad_s_arrays_elementwise_and_back():
    n = [0.0, 150.0, -3000.0]
    w = rpm_to_rad_s(n)
    assert isinstance(w, np.ndarray) and w.shape == (3,)
    assert list(w) == [v * RPM_TO_RAD_S for v in n]
    assert np.allclose(rad_s_to_rpm(w), n, rtol=0, atol=1e-9)
    assert rpm_to_rad_s(True) == RPM_TO_RAD_S   # a bool is a number here, as np.ndim read it
