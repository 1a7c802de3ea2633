"""`dsnake schema` against the experiment files (Debian's python3-jsonschema, draft 2020-12).

Every JSON file under experiments/ validates; a file with an unknown key, a wrong type, an
out-of-range value or an unknown plug-in type is rejected; and docs/experiment-file.md holds
exactly what `dsnake schema --markdown` prints between its markers (the contract cannot drift).
"""
import copy
import json
import os
import pathlib
import subprocess
import unittest

import jsonschema

DSNAKE = os.environ["DSNAKE_EXE"]
SOURCE = pathlib.Path(os.environ["DSNAKE_SOURCE_DIR"])
BEGIN = "<!-- BEGIN GENERATED: dsnake schema --markdown -->\n"
END = "<!-- END GENERATED -->\n"


def run(*args):
    return subprocess.run([DSNAKE, *args], check=True, capture_output=True, text=True).stdout


class SchemaTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.schema = json.loads(run("schema"))
        jsonschema.Draft202012Validator.check_schema(cls.schema)
        cls.validator = jsonschema.Draft202012Validator(cls.schema)
        cls.files = sorted((SOURCE / "experiments").rglob("*.json"))

    def errors(self, document):
        return list(self.validator.iter_errors(document))

    def test_every_experiment_file_validates(self):
        self.assertGreaterEqual(len(self.files), 20)
        for path in self.files:
            with self.subTest(file=str(path.relative_to(SOURCE))):
                self.assertEqual([e.message for e in self.errors(json.loads(path.read_text()))], [])

    def test_unknown_keys_wrong_types_and_ranges_are_rejected(self):
        base = json.loads((SOURCE / "experiments/paper/star_dsnake.json").read_text())
        self.assertEqual(self.errors(base), [])
        cases = {
            "unknown top-level key": lambda d: d.update(colour="red"),
            "unknown energy key": lambda d: d["energies"][0].update(alpah=0.1),
            "unknown field key": lambda d: d["field"].update(sigmaa=1),
            "unknown phase key": lambda d: d["phases"][0].update(iteratons=3),
            "unknown energy type": lambda d: d["energies"][0].update(type="elastic"),
            "wrong type": lambda d: d["field"].update(mu="0.2"),
            "out of range": lambda d: d["energies"][0].update(weight=-1),
            "bad enum": lambda d: d["energies"][2].update(variant="closest"),
            "missing energies": lambda d: d.pop("energies"),
            "unknown phantom key": lambda d: d["image"].update(radiuss=3),
        }
        for name, change in cases.items():
            with self.subTest(case=name):
                d = copy.deepcopy(base)
                change(d)
                self.assertNotEqual(self.errors(d), [], name)

    def test_the_validator_agrees_with_dsnake_validate(self):
        # the same unknown key is refused by dsnake itself (exit 2)
        base = json.loads((SOURCE / "experiments/paper/puzzle_dsnake.json").read_text())
        base["output"] = {"figures": False, "snapshot_evry": 1}
        self.assertNotEqual(self.errors(base), [])
        tmp = pathlib.Path(os.environ.get("TMPDIR", "/tmp")) / f"schema_test_{os.getpid()}.json"
        tmp.write_text(json.dumps(base))
        try:
            r = subprocess.run([DSNAKE, "validate", str(tmp)], capture_output=True, text=True)
        finally:
            tmp.unlink()
        self.assertEqual(r.returncode, 2, r.stderr)
        self.assertIn("output.snapshot_evry", r.stderr)

    def test_the_documented_keys_are_the_generated_ones(self):
        doc = (SOURCE / "docs/experiment-file.md").read_text()
        self.assertIn(BEGIN, doc)
        generated = doc.split(BEGIN, 1)[1].split(END, 1)[0]
        self.assertEqual(generated, run("schema", "--markdown"),
                         "docs/experiment-file.md is stale: run scripts/update_docs.sh")


if __name__ == "__main__":
    unittest.main()
