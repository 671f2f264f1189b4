import numpy as np

from aamcore.evaluation.fits import (
    failure_rates,
    format_failure_table,
    held_out,
    landmark_errors,
    monte_carlo,
    summary,
)
from aamcore.fitting.fitter import Fitter


def test_held_out_excludes_training_subjects(imm_fit_model, imm_set) -> None:
    rest = held_out(imm_fit_model.aam, imm_set.samples)
    assert {s.subject for s in rest} == {"10", "11", "12"}


def test_monte_carlo_table(imm_fit_model, imm_test) -> None:
    fitter = Fitter(imm_fit_model, "multi-resolution")
    records = monte_carlo(fitter, imm_test[:3], offsets=[-40.0, 0.0, 40.0])
    assert len(records) == 3 * 3 * 2 * 2  # images x offsets x axes x starts
    rates = failure_rates(records)
    assert set(rates) == {"cog", "haar"} and set(rates["cog"]) == {"x", "y"}
    table = format_failure_table(rates["haar"])
    assert table.splitlines()[0].split()[:2] == ["Tx", "Fail%"]
    assert "40" in table and "(Tx=0, Ty=0)" in table
    near = [r.nme for r in records if r.offset == 0.0]
    far = [r.nme for r in records if r.offset != 0.0]
    assert np.mean(near) < 0.06
    assert all(r.pt_border <= r.pt_pt + 1e-9 for r in records)
    stats = summary(records)
    assert 0 <= stats["failure_010"] <= 1 and stats["mean_seconds"] > 0
    assert np.mean(far) >= 0.5 * np.mean(near)  # displaced starts are not easier


def test_landmark_errors_fall_back_to_landmark_box(imm_fit_model, imm_test) -> None:
    from dataclasses import replace

    fitter = Fitter(imm_fit_model)
    sample = imm_test[0]
    # An annotation moved far from the face: Haar's box does not match it.
    moved = replace(sample, points=sample.points * 0.3)
    records = landmark_errors(fitter, [sample, moved])
    assert [r.start for r in records] == ["haar", "landmarks"]


def test_held_out_tells_images_by_content_not_by_name(lfpw_fit_model_path, tmp_path) -> None:
    import shutil

    from aamcore.fitting.model import FittingModel
    from aamcore.fitting.training.data import training_set
    from aamcore.io import load_annotated_folder

    aam = FittingModel.load(lfpw_fit_model_path).aam
    # the source names the sets (``lfpw,helen,afw [first 300]``)
    trained = [s for s in training_set(aam.summary["source"].split(" [")[0]).samples
               if s.image_id() in set(aam.summary["train_images"])][:2]
    other = load_annotated_folder(trained[0].image_path.parent, limit=400).samples[-1]
    assert other.image_id() not in set(aam.summary["train_images"])
    # A test folder that reuses a training image's name for another photo, and a training
    # photo under a new name.
    shutil.copy(other.image_path, tmp_path / trained[0].image_path.name)
    stem = trained[0].image_path.stem
    shutil.copy(other.image_path.with_suffix(".pts"), tmp_path / f"{stem}.pts")
    shutil.copy(trained[1].image_path, tmp_path / f"renamed{trained[1].image_path.suffix}")
    shutil.copy(trained[1].image_path.with_suffix(".pts"), tmp_path / "renamed.pts")
    rest = held_out(aam, load_annotated_folder(tmp_path).samples)
    assert [s.image_path.name for s in rest] == [trained[0].image_path.name]
