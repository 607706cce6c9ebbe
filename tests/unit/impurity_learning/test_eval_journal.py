"""The evaluation journal: every finished episode's record is kept as it ends, and a run
started again runs only the episodes it lacks. The episodes here are stand-ins (no simulator): the
journal does not care how a record was made."""

import json
from types import SimpleNamespace

import pytest

from impurity_learning import eval_cli

SEEDS = [900_000_000 + k for k in range(4)]
ARGS = SimpleNamespace(ray=False, ray_address=None, jobs=1, threads=1, device="cpu", no_progress=True)


def tasks(checkpoint: str = "") -> list:
    return [("ours@cell", checkpoint, "random", seed, 1, "cpu", "default", "", "truth") for seed in SEEDS]


@pytest.fixture
def episodes(monkeypatch) -> SimpleNamespace:
    """Stand-in episodes: `ran` lists the seeds run; the episode numbered `interrupt_at` (counting from
    1) is interrupted as by Ctrl-C, once."""
    state = SimpleNamespace(ran=[], interrupt_at=None)

    def stand_in(task):
        if state.interrupt_at == len(state.ran) + 1:
            state.interrupt_at = None
            raise KeyboardInterrupt
        state.ran.append(task[3])
        row, _, scenario, seed, _, _, group, palette, _ = task
        return {"row": row, "scenario": scenario, "seed": seed, "group": group, "palette": palette,
                "actions": seed % 7}

    monkeypatch.setattr(eval_cli, "run_task", stand_in)
    return state


def test_an_interrupted_run_keeps_its_finished_episodes_and_the_next_one_runs_the_rest(tmp_path, episodes):
    journal = tmp_path / "results.partial.jsonl"
    episodes.interrupt_at = 3
    with pytest.raises(KeyboardInterrupt):
        eval_cli.run_episodes(tasks(), {}, journal, ARGS)
    assert len(journal.read_text().splitlines()) == 2  # written as each episode ended
    episodes.ran.clear()
    records = eval_cli.run_episodes(tasks(), {}, journal, ARGS)
    assert episodes.ran == SEEDS[2:]
    assert sorted(r["seed"] for r in records) == SEEDS and all(r["actions"] == r["seed"] % 7 for r in records)


def test_records_are_reused_for_the_same_checkpoint_bytes_only(tmp_path, episodes):
    journal = tmp_path / "results.partial.jsonl"
    eval_cli.run_episodes(tasks("/a/policy.pt"), {"/a/policy.pt": "digest-1"}, journal, ARGS)
    episodes.ran.clear()
    eval_cli.run_episodes(tasks("/b/policy.pt"), {"/b/policy.pt": "digest-1"}, journal, ARGS)
    assert episodes.ran == []  # the same bytes elsewhere: the same episodes
    eval_cli.run_episodes(tasks("/a/policy.pt"), {"/a/policy.pt": "digest-2"}, journal, ARGS)
    assert episodes.ran == SEEDS  # retrained: every episode again


def test_a_line_cut_short_by_a_killed_run_is_skipped_and_spoils_no_other(tmp_path, episodes):
    journal = tmp_path / "results.partial.jsonl"
    key = eval_cli.task_key(tasks()[0], {})
    journal.write_text(json.dumps({"key": key, "record": {"seed": SEEDS[0]}}) + '\n{"key": "cut')
    assert eval_cli.read_journal(journal) == {key: {"seed": SEEDS[0]}}
    eval_cli.run_episodes(tasks(), {}, journal, ARGS)
    assert episodes.ran == SEEDS[1:] and len(eval_cli.read_journal(journal)) == 4


def test_records_are_reused_under_the_same_decision_settings_only(tmp_path, episodes, monkeypatch):
    journal = tmp_path / "results.partial.jsonl"
    eval_cli.run_episodes(tasks(), {}, journal, ARGS)
    episodes.ran.clear()
    monkeypatch.setattr(eval_cli, "settings_digest", lambda: "another-rule")
    eval_cli.run_episodes(tasks(), {}, journal, ARGS)
    assert episodes.ran == SEEDS  # an attention threshold changed: every episode again


def test_the_decision_settings_digest_follows_the_attention_defaults(monkeypatch):
    import dataclasses

    from impurity_attention.core import attention

    shipped = eval_cli.settings_digest()
    eval_cli.settings_digest.cache_clear()
    changed = dataclasses.replace(attention.AttentionParams(), min_relative_contrast=9.0)
    monkeypatch.setattr(attention, "AttentionParams", lambda: changed)
    try:
        assert eval_cli.settings_digest() != shipped
    finally:
        eval_cli.settings_digest.cache_clear()


def test_the_decision_settings_digest_follows_the_attention_model_files(tmp_path, monkeypatch):
    files = {name: tmp_path / name for name in eval_cli.model_files()}
    assert set(files) == {"verifier.json", "impurity_net.pt"}
    for path in files.values():
        path.write_bytes(b"model")
    monkeypatch.setattr(eval_cli, "model_files", lambda: files)
    eval_cli.settings_digest.cache_clear()
    try:
        before = eval_cli.settings_digest()
        eval_cli.settings_digest.cache_clear()
        files["verifier.json"].write_bytes(b"another model")
        assert eval_cli.settings_digest() != before
    finally:
        eval_cli.settings_digest.cache_clear()
