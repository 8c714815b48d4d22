"""`dcdc suite build` / `dcdc suite score` (dcdc.evaluate.suite) on a 2-scene 2-D suite cut
to 0.1 s, scored with an untrained network."""
import json

import pytest

from dcdc.evaluate import suite as S
from dcdc.scene.families import FAMILIES, SUITE_SEED0
from helpers import dcdc



@pytest.fixture(scope="module")
def built(tmp_path_factory):
    d = tmp_path_factory.mktemp("suite")
    index = S.build(2, d / "s", scenes=2, members=2, duration=0.1, progress=False,
                    echo=lambda *a, **k: None)
    return d / "s", index


def test_build(built):
    d, index = built
    assert index["dim"] == 2 and index["members"] == 2 and not index["failed"]
    names = list(index["scenes"])
    assert names == [f"{FAMILIES[0]}_{SUITE_SEED0}_2d", f"{FAMILIES[1]}_{SUITE_SEED0 + 1}_2d"]
    for n, s in index["scenes"].items():
        assert s["seed"] >= SUITE_SEED0 and s["family"] in FAMILIES
        assert 1.1 <= s["density_ratio"] <= 20
        assert len(s["floor"]) == 1
        m = s["floor"][0]
        assert m["stable"] and m["member"] == 1
        assert m["com_height_error"] < 0.01  # 1 µm apart after 0.1 s
        assert (d / "floor" / f"{n}_m1.json").exists()
    from dcdc.data.dataset import Dataset
    t = Dataset(d / "truth")[names[0]]
    assert t.attrs["split"] == "test" and t.n_frames == 6
    assert json.loads((d / "suite.json").read_text())["scenes"].keys() == index["scenes"].keys()


def test_build_resumes(built, capsys):
    d, _ = built
    code, out, err = dcdc(capsys, "suite", "build", "--dim", 2, "-o", d, "--scenes", 2,
                          "--members", 2, "--duration", 0.1, "--no-progress")
    assert code == 0, err
    assert "0 run(s) to do" in out and "2 scenes" in out


def test_score(built, tmp_path, capsys):
    import torch

    from dcdc.model.checkpoint import save_checkpoint
    from dcdc.model.networks import build_network
    d, index = built
    torch.manual_seed(0)
    ck = save_checkpoint(tmp_path / "untrained.pt", build_network("dcdc", 2))
    js = tmp_path / "score.json"
    code, out, err = dcdc(capsys, "suite", "score", "--model", ck, "--suite", d, "--no-contact",
                          "--json", js, "--no-progress")
    assert code == 0, err
    assert "SPH floor" in out and "untrained" in out and "wall contact: untrained off" in out
    res = json.loads(js.read_text())
    groups = {r["group"] for r in res["rows"]}
    assert {"all", FAMILIES[0], FAMILIES[1]} <= groups
    assert any(g.startswith("ratio ") for g in groups)
    for r in res["rows"]:
        assert r["model"] in ("untrained", S.FLOOR)
        assert 0 <= r["order_ok"] <= 1 and 0 <= r["layers_ok"] <= 1
    allm = next(r for r in res["rows"] if r["group"] == "all" and r["model"] == "untrained")
    assert allm["runs"] == 2 and allm["scenes"] == 2
    floor = next(r for r in res["rows"] if r["group"] == "all" and r["model"] == S.FLOOR)
    assert floor["com_within_5pct"] == 1.0 and floor["layers_ok"] == 1.0
    row = res["scenes"][next(iter(index["scenes"]))]["models"]["untrained"]
    assert row["contact"] is False and "curves" not in row


def test_score_bf16_and_a_displaced_member(built, tmp_path):
    """``bf16`` and ``perturb`` reach the rollouts: each moves the untrained network's final
    positions a little (not zero, far below a particle), and the JSON says which ran."""
    import torch

    from dcdc.model.checkpoint import save_checkpoint
    from dcdc.model.networks import build_network
    d, index = built
    torch.manual_seed(0)
    ck = save_checkpoint(tmp_path / "untrained.pt", build_network("dcdc", 2))
    runs = {k: S.score([ck], d, contact=False, progress=False, **kw)
            for k, kw in {"fp32": {}, "bf16": {"bf16": True}, "member": {"perturb": 1e-6}}.items()}
    assert runs["bf16"]["bf16"] and not runs["fp32"]["bf16"] and runs["member"]["perturb_m"] == 1e-6
    name = next(iter(index["scenes"]))
    com = {k: r["scenes"][name]["models"]["untrained"]["com_height_pred"] for k, r in runs.items()}
    for k in ("bf16", "member"):
        dev = max(abs(a - b) for a, b in zip(com[k], com["fp32"]))
        assert 0 < dev < 1e-3, (k, dev)


def test_score_needs_a_suite(tmp_path, capsys):
    code, out, err = dcdc(capsys, "suite", "score", "--model", "x.pt", "--suite", tmp_path)
    assert code == 2 and err.startswith("error:")


def test_summarise_and_bins():
    assert S.ratio_bin(1.1) == S.ratio_bin(1.5) == "ratio 1.1-1.5"
    assert S.ratio_bin(1.51) == "ratio 1.5-3" and S.ratio_bin(19.9) == "ratio 3-20"
    rows = [{"stable": True, "order_ok": True, "com_height_error": 0.04, "layers_ok": True,
             "purity_ratio_min": 0.95, "order_ok_true": True},
            {"stable": True, "order_ok": False, "com_height_error": 0.2, "layers_ok": False,
             "purity_ratio_min": 0.5, "order_ok_true": True},
            {"stable": False, "order_ok": True, "com_height_error": 0.01, "layers_ok": True,
             "purity_ratio_min": 0.9, "order_ok_true": True}]
    s = S.summarise(rows)
    assert s["runs"] == 3 and s["stable"] == 2
    assert s["order_ok"] == pytest.approx(1 / 3) or s["order_ok"] == round(1 / 3, 4)
    assert s["com_within_5pct"] == round(1 / 3, 4)  # a run that stopped early is a miss
    # the purity of the runs to the end: a stopped run's 0.9 is its early, unmixed state
    assert s["purity_ratio_median"] == pytest.approx(0.725)
    assert S.summarise([rows[2]])["purity_ratio_median"] is None


def test_contact_default_is_the_checkpoints(tmp_path):
    """A checkpoint that says it runs alone rolls out without the wall contact unless told
    otherwise; one that says nothing keeps the contact; an explicit flag wins either way."""
    import torch

    from dcdc.evaluate.rollout import NeuralSimulator, uses_contact
    from dcdc.model.checkpoint import load_checkpoint, save_checkpoint
    from dcdc.model.networks import build_network
    from dcdc.api import load_scene

    torch.manual_seed(0)
    net = build_network("dcdc", 2)
    alone = load_checkpoint(save_checkpoint(tmp_path / "alone.pt", net, contact=False))[0]
    quiet = load_checkpoint(save_checkpoint(tmp_path / "quiet.pt", net))[0]
    assert uses_contact(alone) is False and uses_contact(quiet) is True
    assert uses_contact(alone, True) is True and uses_contact(quiet, False) is False
    assert uses_contact(net) is True  # a network never saved says nothing
    system = load_scene("dam_break").realize(dim=2)
    assert NeuralSimulator(alone, system.copy()).contact is None
    assert NeuralSimulator(quiet, system.copy()).contact is not None
    assert NeuralSimulator(alone, system.copy(), contact=True).uses_contact
