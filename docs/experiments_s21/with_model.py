"""Twenty-first session: run pytest with a fitted verifier (verifier-fit --model-json's file) written into
impurity_attention/core/verifier_model.py, then put the shipped file back, whatever pytest answered.

    python docs/experiments_s21/with_model.py runs/s21/verifier_oriented.json tests/unit/impurity_attention
"""
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path[:0] = [str(ROOT / "scripts"), str(ROOT / "docs" / "experiments_s14")]
import calibrate_attention as ca  # noqa: E402
import push_out  # noqa: E402

MODEL_FILE = ROOT / "src/impurity_attention/impurity_attention/core/verifier_model.py"


def main() -> int:
    model, tests = sys.argv[1], sys.argv[2:]
    shipped = MODEL_FILE.read_text()
    try:
        MODEL_FILE.write_text(ca.model_source(push_out.verifier_from_json(model)))
        return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *tests],
                              cwd=ROOT).returncode
    finally:
        MODEL_FILE.write_text(shipped)


if __name__ == "__main__":
    sys.exit(main())
