"""Helpers for users' own test suites: the `seagen verify` gate as one assertion."""

from __future__ import annotations

from seagen.verify.run import verify


def assert_equivalent(folder: str, model: str, **options: object) -> None:
    """Raise AssertionError (with `seagen verify`'s report) unless the C in `folder` is `model`.

    Options are those of `seagen verify`: prefix, data, vectors, core, features. Example::

        from seagen.testing import assert_equivalent

        def test_firmware_model_is_the_trained_one():
            assert_equivalent("firmware/model", "models/mlp_calibration.pt", vectors=20_000)
    """
    verdict = verify(folder, model, **options)  # type: ignore[arg-type]
    if not verdict.ok:
        raise AssertionError(verdict.text())
