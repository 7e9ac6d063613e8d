"""Payload columns of measurement files: payload_kg and the centre payload_x, payload_y, payload_z."""

from __future__ import annotations

import numpy as np
import pytest

import pincal
from pincal.calibration.measurements import MeasurementData
from pincal.errors import BadMeasurementData

HEADER = "joint1,joint2,x,y,z"


def _write(tmp_path, text: str):
    path = tmp_path / "meas.csv"
    path.write_text(text)
    return path


def test_payload_columns_are_read_and_written_back(planar, tmp_path):
    path = _write(
        tmp_path,
        HEADER + ",payload_kg,payload_x,payload_y,payload_z\n"
        "0.1,0.2,1.0,0.5,0.0,0,0,0,0\n"
        "0.3,-0.4,1.2,0.4,0.0,25.5,0.01,0.0,0.2\n",
    )
    data = MeasurementData.from_csv(path, planar)
    np.testing.assert_array_equal(data.payload, [[0, 0, 0, 0], [25.5, 0.01, 0.0, 0.2]])
    assert not data.payload.flags.writeable
    again = tmp_path / "again.csv"
    data.to_csv(again)
    np.testing.assert_array_equal(MeasurementData.from_csv(again, planar).payload, data.payload)
    np.testing.assert_array_equal(data.subset([1]).payload, data.payload[[1]])


def test_payload_mass_alone_and_millimetres(planar, tmp_path):
    data = MeasurementData.from_csv(
        _write(tmp_path, HEADER + ",payload_kg\n0.1,0.2,1000,500,0,12\n"), planar, millimetres=True
    )
    np.testing.assert_array_equal(data.payload, [[12, 0, 0, 0]])
    path = _write(
        tmp_path, HEADER + ",payload_kg,payload_x,payload_y,payload_z\n0.1,0.2,1000,500,0,12,10,0,200\n"
    )
    data = MeasurementData.from_csv(path, planar, millimetres=True)
    np.testing.assert_allclose(data.payload, [[12, 0.01, 0, 0.2]])  # the centre in the coordinates' unit
    text = data.to_csv_text(millimetres=True)
    assert text.splitlines()[0].endswith("payload_kg,payload_x,payload_y,payload_z")
    assert text.splitlines()[1].endswith("12.0,10.0,0.0,200.0")


def test_no_payload_columns_no_payload(planar, tmp_path):
    data = MeasurementData.from_csv(_write(tmp_path, HEADER + "\n0.1,0.2,1,0.5,0\n"), planar)
    assert data.payload is None
    assert "payload" not in data.to_csv_text()


@pytest.mark.parametrize(
    "columns, row, match",
    [
        (",payload_x,payload_y,payload_z", ",0,0,0", "valid: payload_kg"),
        (",payload_kg,payload_x", ",1,0", "all three"),
        (",payload_kg,payload_mass", ",1,2", "valid: payload_kg"),
        (",payload_kg", ",-3", "line 2: payload_kg -3.0 must be from 0"),
        (",payload_kg", ",1e9", "must be from 0 to 100000 kg"),
    ],
)
def test_bad_payload_columns_name_the_problem(planar, tmp_path, columns, row, match):
    with pytest.raises(BadMeasurementData, match=match):
        MeasurementData.from_csv(
            _write(tmp_path, HEADER + columns + "\n0.1,0.2,1,0.5,0" + row + "\n"), planar
        )


def test_payload_from_the_api_is_checked():
    with pytest.raises(BadMeasurementData, match="2 rows"):
        MeasurementData(np.zeros((2, 2)), np.zeros((2, 3)), ("a", "b"), payload=np.zeros((3, 4)))
    data = MeasurementData(
        np.zeros((2, 2)), np.zeros((2, 3)), ("a", "b"), payload=[[1, 0, 0, 0], [2, 0, 0, 0.1]]
    )
    assert data.payload.shape == (2, 4)
    assert pincal.MeasurementData is MeasurementData
