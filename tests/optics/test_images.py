"""The FLIP map on the box around the differing pixels against FLIP on the whole images."""

import flip_evaluator
import numpy as np

from pipeline.optics import images


def whole_flip(reference8, test8):
    err, _, _ = flip_evaluator.evaluate(reference8.astype(np.float32) / 255.0, test8.astype(np.float32) / 255.0,
                                        "LDR", applyMagma=False)
    return np.asarray(err)[..., 0]


def planted_pairs(count, seed=0):
    """Noise images and smooth ones with a hard edge, each with a few patches changed anywhere
    (against an edge of the image too), of sizes from below FLIP's reach to a few times it."""
    rng = np.random.default_rng(seed)
    for trial in range(count):
        h, w = rng.integers(12, 120, 2)
        if trial % 2:
            a = rng.integers(0, 256, (h, w, 3)).astype(np.uint8)
        else:
            y, x = np.mgrid[:h, :w]
            a = np.stack([128 + 100 * np.sin(x / 7 + c) * (y > h // 2) for c in range(3)], -1).astype(np.uint8)
        b = a.copy()
        for _ in range(rng.integers(1, 4)):
            y0, x0 = rng.integers(0, h), rng.integers(0, w)
            dy, dx = rng.integers(1, 12, 2)
            b[y0:y0 + dy, x0:x0 + dx] = np.clip(b[y0:y0 + dy, x0:x0 + dx] + rng.integers(-40, 41, 3), 0, 255)
        yield a, b


def test_flip_on_the_box_of_the_differences_is_flip_on_the_whole_images_bit_for_bit():
    for a, b in planted_pairs(60):
        np.testing.assert_array_equal(images.flip_map(a, b), whole_flip(a, b))
    a, _ = next(planted_pairs(1))
    assert not images.flip_map(a, a).any()


def test_the_box_needs_flip_s_whole_reach(monkeypatch):
    # One pixel less and a pixel at the box's edge sees a clamped border FLIP does not: the values differ.
    monkeypatch.setattr(images, "FLIP_REACH", images.FLIP_REACH - 1)
    assert any(not np.array_equal(images.flip_map(a, b), whole_flip(a, b)) for a, b in planted_pairs(20))
