"""Report figures of a run with a sensor map name each response by point and kind."""

from types import SimpleNamespace

from nlid_lab.campaign import parse_campaign, run_campaign
from nlid_lab.reports import _figures as figures, _report as report, all_level_frfs, load_run
from test_campaign_sensors import BASE, EXAMPLES, short
from test_figures import sdof_frf

LABELS = ["drive (acceleration)", "joint (acceleration)", "payload (acceleration)"]


def legend(ax) -> list[str]:
    return [t.get_text() for t in ax.get_legend().get_texts()]


def test_coherence_and_level_change_figures_name_points_and_kinds(tmp_path):
    data = short(BASE)
    data["random"]["levels"] = [2.0, 20.0]
    run_campaign(parse_campaign(data, EXAMPLES), tmp_path / "s.h5")
    run = load_run(tmp_path / "s.h5")
    names = report.channel_names(run)
    assert names == (LABELS, ["drive"])
    frfs = all_level_frfs(run)
    secs = report.frf_sections(frfs, names)
    coherence = dict(secs[1].figures)
    titles = [coherence[f"coherence_levels_out{q}"].axes[0].get_title() for q in range(3)]
    assert titles == [f"Multiple coherence, response {label} (linear analysis)"
                      for label in LABELS]
    frf_titles = [fig._suptitle.get_text() for _, fig in secs[0].figures]
    assert frf_titles[1] == "FRF per level: response joint (acceleration) / force at drive"
    change = report.level_change_section(run)
    assert change is not None
    lines = legend(dict(change.figures)["level_change"].axes[0])
    assert lines[:3] == [f"response {label}" for label in LABELS]
    assert not any("DOF" in text for text in lines + titles + frf_titles)


def test_without_a_map_the_figures_say_dof():
    frfs = [sdof_frf(2.0), sdof_frf(8.0)]
    assert "response DOF 0" in figures.multiple_coherence_levels(frfs, 0).axes[0].get_title()
    change = SimpleNamespace(z=frfs[0].multiple_coherence, freqs=frfs[0].freqs, threshold=9.0,
                             summary=SimpleNamespace(labels=("2 N rms", "8 N rms")))
    assert legend(figures.level_change(change).axes[0])[0] == "response DOF 0"
    names = (["tip (velocity)"], ["tip"])
    assert legend(figures.level_change(change, names).axes[0])[0] == "response tip (velocity)"


def test_bla_figure_names_point_and_kind():
    frfs = [sdof_frf(2.0), sdof_frf(8.0)]
    for frf in frfs:
        g = frf.H[:, :, 0]
        frf.bla = SimpleNamespace(freqs=frf.freqs, G=g, var_total=abs(g) ** 2 * 1e-2,
                                  var_noise=abs(g) ** 2 * 1e-4)
    title = figures.bla_levels(frfs, 0, (["tip (velocity)"], ["root"])).axes[0].get_title()
    assert title == "Best linear approximation, response tip (velocity) / force at root"


def test_report_of_a_mixed_kind_sensor_run(tmp_path):
    """`nlid-lab report` on a campaign run mapping 3 of 11 points in two kinds: FRFs in the
    highest kind (as analyze reads them), figures named by point and measured kind."""
    from nlid_lab.cli import main
    data = short(BASE)
    data["random"]["levels"] = [2.0, 20.0]
    data["sensors"]["response_kinds"] = ["acceleration", "acceleration", "displacement"]
    run_campaign(parse_campaign(data, EXAMPLES), tmp_path / "m.h5")
    assert main(["report", str(tmp_path / "m.h5"), "--out", str(tmp_path / "rep")]) == 0
    assert (tmp_path / "rep" / "level_change.png").exists()
    assert [f.response_kind for f in all_level_frfs(load_run(tmp_path / "m.h5"))] == \
        ["acceleration"] * 2
