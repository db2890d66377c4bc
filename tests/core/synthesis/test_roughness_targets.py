"""The fill's roughness targets: even over their range, smooth, seeded."""

import numpy as np

from terrasynth_core.synthesis.roughness import LOWEST, roughness_targets


def test_targets_spread_evenly_over_the_map_and_vary_over_about_a_patch():
    u = roughness_targets((400, 600), seed=3, patch_size=40)
    assert u.shape == (400, 600) and u.dtype == np.float32
    assert LOWEST <= u.min() and u.max() <= 1.0
    # Every fifth of the range covers about a fifth of the map.
    shares = np.histogram(u, bins=5, range=(LOWEST, 1))[0] / u.size
    assert np.all(np.abs(shares - 0.2) < 0.05)
    # Neighbouring cells differ little; cells a few patches apart freely.
    assert np.abs(np.diff(u, axis=1)).max() < 0.05
    assert np.abs(u[:, 160:] - u[:, :-160]).mean() > 0.15


def test_targets_are_the_seeds():
    a = roughness_targets((200, 200), seed=1, patch_size=32)
    np.testing.assert_array_equal(a, roughness_targets((200, 200), seed=1, patch_size=32))
    assert np.abs(a - roughness_targets((200, 200), seed=2, patch_size=32)).mean() > 0.07
