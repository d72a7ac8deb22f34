"""Any plant: python-control systems, polytopes, the PID and integral forms, model files."""

from pathlib import Path

import control as ct
import numpy as np
import pytest

import scara_robust as sr
from scara_robust.cli import main
from scara_robust.robustness.polytope import box_closed_loops

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
#: The classic quadratically stable triple (autonomous polytope).
TRIPLE = np.array([[[-1.0, 2.0], [1.0, -3.0]], [[-0.8, 1.5], [1.3, -2.7]], [[-1.4, 0.9], [0.7, -2.0]]])


# ---------------------------------------------------------------- python-control systems


def test_from_system_statespace_and_transfer_function_agree():
    G = ct.tf([2.0], [1.0, 3.0, 2.0])
    elements = [("A", 0, 1, -0.1, 0.2), sr.UncertainElement("B", 0, 0, 0.0, 0.5)]
    from_tf = sr.UncertainLTVModel.from_system(G, elements)
    from_ss = sr.UncertainLTVModel.from_system(ct.ss(G), elements)
    assert np.array_equal(from_tf.A, from_ss.A) and np.array_equal(from_tf.B, from_ss.B)
    assert from_tf.elements == from_ss.elements and from_tf.elements[1] == elements[1]


def test_from_system_refuses_discrete_time_and_non_systems():
    with pytest.raises(sr.ArgumentValueError, match="`sys` must be continuous-time"):
        sr.UncertainLTVModel.from_system(ct.c2d(ct.ss(ct.tf([1], [1, 1])), 0.01))
    with pytest.raises(sr.ArgumentTypeError, match="`sys` must be a control.StateSpace"):
        sr.UncertainLTVModel.from_system("motor")


def test_one_indexing_convention():
    el = sr.UncertainElement("A", 2, 2, 0.0, 1.0)
    model = sr.UncertainLTVModel(np.eye(3), np.ones((3, 1)), (el,))
    assert el.label == "ΔA[2, 2]"
    assert model.to_pandas()[["label", "row", "col"]].values.tolist() == [["ΔA[2, 2]", 2, 2]]


# ---------------------------------------------------------------- PID and integral forms


def test_pid_augment_one_joint_by_hand():
    # θ̈ = a θ + c θ̇ + g u with a = -1, c = -2, g = 5; e = r − θ ⇒ ë = a e + c ė − g u
    motor = ct.ss([[0, 1], [-1, -2]], [[0], [5]], [[1, 0]], 0)
    model = sr.pid_augment(motor, [("A", 1, 1, -0.5, 0.25), ("B", 1, 0, 1.0, 2.0)])
    assert np.array_equal(model.A, [[0, 1, 0], [0, 0, 1], [0, -1, -2]])
    assert np.array_equal(model.B, [[0], [0], [-5]])
    assert model.elements == (
        sr.UncertainElement("A", 2, 2, -0.5, 0.25),  # damping keeps its sign
        sr.UncertainElement("B", 2, 0, -2.0, -1.0),  # the input gain flips: [1, 2] -> [-2, -1]
    )
    assert model.n_joints == 1


def test_pid_augment_two_joints_by_hand():
    Aq = np.array([[-1.0, 0.5], [0.2, -3.0]])
    Av = np.array([[-0.1, 0.0], [0.0, -0.2]])
    Bu = np.array([[2.0, 0.1], [0.1, 4.0]])
    plant = ct.ss(np.block([[np.zeros((2, 2)), np.eye(2)], [Aq, Av]]), np.vstack([np.zeros((2, 2)), Bu]),
                  np.hstack([np.eye(2), np.zeros((2, 2))]), 0)
    model = sr.pid_augment(plant, [("A", 3, 0, 0.0, 1.0), ("B", 2, 1, -0.3, 0.1)])
    expected_A = np.zeros((6, 6))
    expected_A[0:2, 2:4] = np.eye(2)
    expected_A[2:4, 4:6] = np.eye(2)
    expected_A[4:6, 2:4] = Aq
    expected_A[4:6, 4:6] = Av
    assert np.array_equal(model.A, expected_A)
    assert np.array_equal(model.B, np.vstack([np.zeros((4, 2)), -Bu]))
    # plant row 3 (q̈2), column 0 (q1) -> model row 5 (ë2), column 2 (e1); B row 2 -> row 4, sign flipped
    assert model.elements == (sr.UncertainElement("A", 5, 2, 0.0, 1.0), sr.UncertainElement("B", 4, 1, -0.1, 0.3))
    table = sr.augment_table(plant, [("A", 3, 0, 0.0, 1.0), ("B", 2, 1, -0.3, 0.1)])
    assert table["model"].tolist() == ["ΔA[5, 2]", "ΔB[4, 1]"] and table["sign"].tolist() == [1, -1]


def test_pid_augment_refuses_other_forms():
    with pytest.raises(sr.ArgumentValueError, match="second-order form"):
        sr.pid_augment(ct.ss([[0, 1], [-1, -2]], [[1], [5]], [[1, 0]], 0))
    with pytest.raises(sr.ArgumentValueError, match="kinematic row"):
        sr.pid_augment(ct.ss([[0, 1], [-1, -2]], [[0], [5]], [[1, 0]], 0), [("A", 0, 1, 0.0, 1.0)])


def test_integral_augment_by_hand():
    # ẋ = A x + B u, y = C x; z = ∫(r − y): ż = −C x
    A, B, C = np.array([[-1.0, 2.0], [0.0, -3.0]]), np.array([[0.0], [1.0]]), np.array([[1.0, 0.0]])
    model = sr.integral_augment(ct.ss(A, B, C, 0), [("A", 0, 1, -0.5, 0.5), ("B", 1, 0, 0.5, 1.5)])
    assert np.array_equal(model.A, [[0, -1, 0], [0, -1, 2], [0, 0, -3]])
    assert np.array_equal(model.B, [[0], [0], [1]])
    assert model.elements == (sr.UncertainElement("A", 1, 2, -0.5, 0.5), sr.UncertainElement("B", 2, 0, 0.5, 1.5))


# ---------------------------------------------------------------- gains a user can implement


def test_pid_matrices_reproduce_u_equals_minus_kx():
    d = sr.design(sr.paper_model(), 3, 90)
    K_I, K_P, K_D = d.pid_matrices()
    rng = np.random.default_rng(1)
    for x in rng.normal(size=(20, 6)):
        assert np.allclose(K_I @ x[:2] + K_P @ x[2:4] + K_D @ x[4:], -d.K @ x, rtol=1e-13, atol=1e-10)
    # the python-control controller gives the same u for the same (∫e, e, ė)
    ctrl = d.controller()
    x = rng.normal(size=6)
    u = ctrl.C @ x[:2] + ctrl.D @ x[2:]
    assert np.allclose(u, -d.K @ x, rtol=1e-13)
    with pytest.raises(sr.ArgumentValueError, match="PID form"):
        sr.design(sr.UncertainLTVModel([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]]), 1, 2).pid_matrices()


def test_python_control_closed_loop_of_a_vertex_has_the_numpy_eigenvalues():
    model = sr.paper_model()
    d = sr.design(model, 3, 90)
    A_v, B_v = model.matrices_at(model.upper_bounds())
    ours = np.sort_complex(np.linalg.eigvals(A_v - B_v @ d.K))
    theirs = np.sort_complex(d.closed_loop(A_v, B_v).poles())
    assert np.allclose(ours, theirs, rtol=1e-9)


# ---------------------------------------------------------------- polytopes


def test_three_matrix_polytope_is_certified_and_its_box_hull_is_not():
    poly = sr.PolytopicModel(TRIPLE, np.zeros((3, 2, 1)), name="triple")
    loops = poly.closed_loops(np.zeros((1, 2)))
    if sr.cvxpy_available():
        lmi = sr.lmi_certificate(loops)
        assert lmi.certified and lmi.P is not None
        max_vertex_eig, decay = sr.verify_lyapunov(loops, lmi.P)
        assert max_vertex_eig < 0 and decay > 0 and np.all(np.linalg.eigvalsh(lmi.P) > 0)
        for A in TRIPLE:  # numpy, independently: AᵀP + PA ≺ 0 at every vertex
            assert np.linalg.eigvalsh(A.T @ lmi.P + lmi.P @ A).max() < 0
    hull = poly.box_hull()
    corners = box_closed_loops(hull, np.zeros((1, 2)))
    assert (np.linalg.eigvals(corners).real.max(axis=1) > 0).any()  # the box admits unstable matrices
    cert = sr.polytope_certificate(corners, np.eye(2))
    assert cert.n_unstable > 0 and not cert.certifiable


def test_polytope_from_systems_and_theorem1_refusal():
    systems = [ct.ss(A, [[0.0], [1.0]], np.eye(2), 0) for A in TRIPLE]
    poly = sr.PolytopicModel.from_systems(systems)
    assert poly.n_vertices == 3 and np.allclose(poly.A, TRIPLE.mean(axis=0))
    d = sr.design(poly, 1.0, 2.0)
    assert sr.vertex_certificate(poly, d).certified
    with pytest.raises(sr.ArgumentTypeError, match="Theorem 1 needs interval elements: use vertex_certificate"):
        sr.certify(poly, d)
    table = sr.certificate_table(poly, d, falsifier_tries=2).set_index("method")
    assert table.loc["theorem1-all", "verdict"] == "skipped" and table.loc["vertex-polytope", "certified"]


def test_certificate_table_on_a_model_without_parameters_skips_the_physical_rows():
    motor = sr.load_model(EXAMPLES / "plant-dc-motor-elements.toml")
    table = sr.certificate_table(motor, sr.design(motor, 1, 2), falsifier_tries=2).set_index("method")
    assert table.loc["theorem1-all", "certified"] and table.loc["vertex-box", "certified"]
    for method in ("physical-polytope", "lmi-physical", "falsifier-physical"):
        assert table.loc[method, "verdict"] == "skipped" and "physical parameters" in table.loc[method, "detail"]


# ---------------------------------------------------------------- model files and the command line


@pytest.mark.parametrize("name", ["plant-dc-motor", "plant-dc-motor-elements", "plant-polytope"])
def test_certify_design_and_surface_take_model_files(capsys, name):
    import json

    path = str(EXAMPLES / f"{name}.toml")
    assert main(["certify", "--model", path, "--rho", "1", "--eta", "2", "--format", "json", "--tries", "2"]) == 0
    rows = {r["method"]: r for r in json.loads(capsys.readouterr().out)}
    applicable = {m for m, r in rows.items() if r["verdict"] != "skipped"}
    # the table's rows, then the design's decay rate and loop margins (summary records after them)
    assert rows["decay-rate"]["verdict"] == "certified" and rows["loop-margins"]["verdict"] == "frozen loops stable"
    applicable -= {"loop-margins", "input-limits", "max-ts"}  # the headline: the largest certified Ts, or why none
    assert list(rows)[0] == "max-ts"
    expected = {"vertex-polytope", "lmi-polytope", "falsifier-polytope"} if name.endswith("polytope") else {
        "theorem1-all", "theorem1-A", "theorem1-B", "vertex-box", "lmi-box", "falsifier-box"}
    expected.add("decay-rate")
    if name == "plant-dc-motor":  # physical parameters: its frozen plants on the parameter grid are tested too
        expected |= {"physical-polytope", "lmi-physical", "falsifier-physical"}
    assert applicable == expected
    assert main(["design", "--model", path, "--rho", "1", "--eta", "2"]) == 0
    assert "closed loop Hurwitz: True" in capsys.readouterr().out
    assert main(["surface", "--model", path, "--rho", "0.5:2:3", "--eta", "1:4:3"]) == 0
    assert "9 grid points" in capsys.readouterr().out


def _bad_files(tmp):
    good = (EXAMPLES / "plant-dc-motor-elements.toml").read_text()
    cases = {
        "missing-B": (good.replace("B = [[0.0],\n     [83.333]]", ""), "missing field `B`"),
        "shape": (good.replace("B = [[0.0],\n     [83.333]]", "B = [[0.0, 1.0, 2.0]]"),
                  "field `B` must have shape (2, n)"),
        "vertex-size": ((EXAMPLES / "plant-polytope.toml").read_text().replace(
            "A = [[-0.8, 1.5], [1.3, -2.7]]", "A = [[-0.8, 1.5, 0], [1.3, -2.7, 0], [0, 0, 1]]"),
            "field `vertices[1].A` must have shape (2, 2)"),
        "non-finite": (good.replace("[0.0, -0.16667]", "[0.0, nan]"), "field `A` must hold finite numbers"),
        "outside": (good.replace("row = 1\ncol = 1", "row = 1\ncol = 5"),
                    "field `elements[0]`: ΔA[1, 5] lies outside A"),
    }
    paths = {}
    for name, (text, needle) in cases.items():
        path = tmp / f"{name}.toml"
        path.write_text(text)
        paths[name] = (path, needle)
    return paths


@pytest.mark.parametrize("case", ["missing-B", "shape", "vertex-size", "non-finite", "outside"])
def test_bad_model_files_get_one_line_naming_file_and_field(tmp_path, capsys, case):
    path, needle = _bad_files(tmp_path)[case]
    with pytest.raises(sr.InputFileError, match=None):
        sr.load_model(path)
    assert main(["certify", "--model", str(path), "--rho", "1", "--eta", "2"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("scara_robust: error: `--model`") and str(path) in err
    assert needle in err


def test_model_file_excludes_the_robots_options(capsys):
    argv = ["design", "--model", str(EXAMPLES / "plant-dc-motor-elements.toml"), "--rho", "1", "--eta", "2",
            "--bounds", "paper"]
    assert main(argv) == 2
    assert "--bounds describe the SCARA" in capsys.readouterr().err
