"""Twenty-first session: run pytest with a fitted verifier (verifier-fit --model-json's file) written into
impurity_attention/core/verifier_model.py, and optionally another default verifier_last_look in attention.py,
then put the shipped files back, whatever pytest answered. It rewrites the checkout's source files while
pytest runs: run it in a clone of its own (with its own `make setup`), never beside a job reading this one's.
--network W (thirty-seventh session): the impurity network W is put where the shipped one is read
(impurity_net.SHIPPED_NETWORK) while pytest runs, and the shipped one (if any) put back after, as the model
and attention.py are.

    python docs/experiments_s21/with_model.py runs/s21/verifier_oriented.json [--last-look T] \
        [--network W] tests/unit/impurity_attention
"""
import argparse
import pathlib
import re
import shutil
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT / "scripts"), str(ROOT / "docs" / "experiments_s14")]
import calibrate_attention as ca  # noqa: E402
import push_out  # noqa: E402

CORE = ROOT / "src/impurity_attention/impurity_attention/core"
MODEL_FILE, ATTENTION_FILE = CORE / "verifier_model.py", CORE / "attention.py"
LAST_LOOK_LINE = re.compile(r"^    verifier_last_look: float = [0-9.]+$", re.MULTILINE)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model")
    parser.add_argument("--last-look", type=float, default=None)
    parser.add_argument("--network", type=pathlib.Path, default=None)
    args, tests = parser.parse_known_args()
    shipped_model, shipped_attention = MODEL_FILE.read_text(), ATTENTION_FILE.read_text()
    assert LAST_LOOK_LINE.search(shipped_attention), "attention.py's verifier_last_look line moved"
    from impurity_attention.core.impurity_net import SHIPPED_NETWORK
    shipped_network = SHIPPED_NETWORK.read_bytes() if SHIPPED_NETWORK.exists() else None
    try:
        if args.network is not None:
            SHIPPED_NETWORK.parent.mkdir(exist_ok=True)
            shutil.copyfile(args.network, SHIPPED_NETWORK)
        MODEL_FILE.write_text(ca.model_source(push_out.verifier_from_json(args.model)))
        if args.last_look is not None:
            ATTENTION_FILE.write_text(LAST_LOOK_LINE.sub(
                f"    verifier_last_look: float = {args.last_look!r}", shipped_attention, count=1))
        return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *tests],
                              cwd=ROOT).returncode
    finally:
        MODEL_FILE.write_text(shipped_model)
        ATTENTION_FILE.write_text(shipped_attention)
        if args.network is not None and shipped_network is None:
            SHIPPED_NETWORK.unlink(missing_ok=True)
        elif args.network is not None:
            SHIPPED_NETWORK.write_bytes(shipped_network)


if __name__ == "__main__":
    sys.exit(main())
