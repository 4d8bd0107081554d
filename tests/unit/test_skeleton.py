"""vehil new estimator --wrap: what it refuses, naming what to do."""

import pytest

from vehil import project, skeleton


def test_a_wrapper_needs_its_library_vendored_in_third_party(
    tmp_path, monkeypatch, request
) -> None:  # noqa: ANN001, E501
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("VEHIL_PROJECT", raising=False)
    skeleton.new_project(tmp_path)
    project.current.cache_clear()
    request.addfinalizer(project.current.cache_clear)  # the next test finds its own
    elsewhere = tmp_path / "filter.h"
    elsewhere.write_text("typedef struct { float x; } filter_t;\n")
    with pytest.raises(skeleton.SkeletonError, match="is not in .*third_party: copy the library"):
        skeleton.new_wrapper("wrapped", elsewhere)
    lib = tmp_path / "third_party" / "nostate"
    lib.mkdir(parents=True)
    (lib / "nostate.h").write_text("float nostate_step(float x);\n")
    with pytest.raises(skeleton.SkeletonError, match="no typedef struct found"):
        skeleton.new_wrapper("wrapped", lib / "nostate.h")
    assert not (tmp_path / "c" / "wrapped.c").exists()  # nothing half-written


def test_both_templates_write_the_one_float32_step(tmp_path, monkeypatch, request) -> None:  # noqa: ANN001
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("VEHIL_PROJECT", raising=False)
    skeleton.new_project(tmp_path)
    project.current.cache_clear()
    request.addfinalizer(project.current.cache_clear)
    lib = tmp_path / "third_party" / "flt"
    lib.mkdir(parents=True)
    (lib / "flt.h").write_text("typedef struct { float x; } flt_t;\n")
    skeleton.new_estimator("lowp")
    skeleton.new_wrapper("wrapped", lib / "flt.h")
    plain = (tmp_path / "c" / "lowp.c").read_text()
    wrapped = (tmp_path / "c" / "wrapped.c").read_text()
    assert skeleton._f32_step(8 * " ") in plain
    note = " /* the skeleton's: VEHIL_SLOT_AS(flt_t, s->lib)'s */"
    assert skeleton._f32_step(4 * " ", note) in wrapped
    assert "STATUS_NOT_FINITE" in skeleton.F32_STEP
