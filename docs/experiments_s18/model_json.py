"""A verifier_model.py from the history (`git show <commit>:<its path> > FILE`) as the JSON
`push_out.py run --verifier` reads (the fields of verifier.RegionVerifier).

    python docs/experiments_s18/model_json.py runs/s18/verifier_model_s16.py runs/s18/verifier_s16.json
"""
import dataclasses
import json
import pathlib
import sys


def main(source: str, out: str) -> None:
    text = pathlib.Path(source).read_text().replace("from .verifier import",
                                                    "from impurity_attention.core.verifier import")
    namespace = {}
    exec(compile(text, source, "exec"), namespace)  # noqa: S102 - a model file of this repository's history
    model = namespace["MODEL"]
    # the form verifier-fit --model-json writes
    pathlib.Path(out).write_text(json.dumps(dataclasses.asdict(model), indent=1))
    print(f"{out}: threshold {model.threshold}")


if __name__ == "__main__":
    main(*sys.argv[1:3])
