#!/usr/bin/python3
"""make bench's merge into BENCHMARKS.md (scripts/bench_merge.py): the measured sections replace
their blocks and nothing else; the shipped BENCHMARKS.md has a block for every benchmark script.
No build, ROS or benchmark run needed.

    /usr/bin/python3 test/scripts/test_bench_merge.py [--xml RESULT.xml] [unittest options]
"""
import glob
import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
import junit_result  # noqa: E402

PKG = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
sys.path.insert(0, os.path.join(PKG, "scripts"))
import bench_merge  # noqa: E402

TOPICS = [("Camera", ["scripts/bench/a.sh", "scripts/bench/b.sh"]),
          ("Wheels", ["scripts/bench/c.sh"])]

DOC = """# Benchmarks

## Camera

<!-- make bench: scripts/bench/a.sh: First -->

### First

old figure 1

<!-- make bench: end -->

Hand-written analysis of the first figure.

<!-- make bench: scripts/bench/a.sh: Second -->

#### Second

old figure 2

<!-- make bench: end -->

More analysis.

## Wheels

Wheels intro by hand.

## Robustness

Runs by hand.
"""


def block(doc, script, heading):
    for item in bench_merge.parse(doc):
        if not isinstance(item, str) and item[:2] == (script, heading):
            return item[2]
    return None


class MergeTest(unittest.TestCase):
    def test_measured_sections_replace_their_blocks_and_nothing_else(self):
        out = bench_merge.merge(DOC, TOPICS, {
            "scripts/bench/a.sh": "### First\n\nnew figure 1\n\n#### Second\n\nnew figure 2\n"})
        self.assertIn("new figure 1", out)
        self.assertIn("new figure 2", out)
        self.assertNotIn("old figure", out)
        for kept in ["Hand-written analysis of the first figure.", "More analysis.",
                     "Wheels intro by hand.", "Runs by hand."]:
            self.assertIn(kept, out)
        # The analysis stays between the two sections it was written between.
        self.assertLess(out.index("new figure 1"), out.index("Hand-written analysis"))
        self.assertLess(out.index("Hand-written analysis"), out.index("new figure 2"))

    def test_same_output_same_document(self):
        outputs = {"scripts/bench/a.sh": "### First\n\nold figure 1\n\n#### Second\n\nold figure 2"}
        self.assertEqual(bench_merge.merge(DOC, TOPICS, outputs), DOC)

    def test_a_script_without_output_is_left_alone(self):
        self.assertEqual(bench_merge.merge(DOC, TOPICS, {}), DOC)

    def test_a_new_section_follows_its_scripts_last_block(self):
        out = bench_merge.merge(DOC, TOPICS, {
            "scripts/bench/a.sh": "### First\n\nf1\n\n#### Second\n\nf2\n\n### Third\n\nf3\n"})
        self.assertEqual(block(out, "scripts/bench/a.sh", "Third"), "### Third\n\nf3")
        self.assertLess(out.index("More analysis."), out.index("## Wheels"))
        self.assertLess(out.index("f2"), out.index("f3"))
        self.assertLess(out.index("f3"), out.index("## Wheels"))

    def test_a_section_the_script_no_longer_prints_goes(self):
        out = bench_merge.merge(DOC, TOPICS, {"scripts/bench/a.sh": "### First\n\nf1\n"})
        self.assertIsNone(block(out, "scripts/bench/a.sh", "Second"))
        self.assertNotIn("old figure 2", out)
        self.assertIn("More analysis.", out)

    def test_a_new_script_goes_after_its_topics_blocks_or_at_the_topics_end(self):
        out = bench_merge.merge(DOC, TOPICS, {"scripts/bench/b.sh": "### B\n\nfb\n",
                                              "scripts/bench/c.sh": "### C\n\nfc\n"})
        # b.sh: after a.sh's last block; c.sh: at the end of "## Wheels", before "## Robustness".
        self.assertLess(out.index("old figure 2"), out.index("fb"))
        self.assertLess(out.index("fb"), out.index("More analysis."))
        self.assertLess(out.index("Wheels intro by hand."), out.index("fc"))
        self.assertLess(out.index("fc"), out.index("## Robustness"))
        # Merged again with the same output, nothing moves.
        again = bench_merge.merge(out, TOPICS, {"scripts/bench/b.sh": "### B\n\nfb\n",
                                                "scripts/bench/c.sh": "### C\n\nfc\n"})
        self.assertEqual(again, out)

    def test_a_missing_topic_is_added_at_the_end(self):
        topics = TOPICS + [("Other benchmarks", ["scripts/bench/d.sh"])]
        out = bench_merge.merge(DOC, topics, {"scripts/bench/d.sh": "### D\n\nfd\n"})
        self.assertLess(out.index("Runs by hand."), out.index("## Other benchmarks"))
        self.assertLess(out.index("## Other benchmarks"), out.index("fd"))

    def test_a_section_without_heading_is_a_block_too(self):
        doc = "# B\n\n<!-- make bench: scripts/bench.sh -->\n\nold\n\n<!-- make bench: end -->\n"
        out = bench_merge.merge(doc, [("", ["scripts/bench.sh"])], {"scripts/bench.sh": "new\n"})
        self.assertEqual(out, doc.replace("old", "new"))

    def test_broken_markers_are_refused(self):
        for doc in ["<!-- make bench: end -->\n",
                    "<!-- make bench: scripts/bench/a.sh: A -->\ntext\n",
                    "<!-- make bench: scripts/bench/a.sh: A -->\n"
                    "<!-- make bench: scripts/bench/a.sh: B -->\n<!-- make bench: end -->\n"]:
            with self.assertRaises(bench_merge.MarkerError, msg=doc):
                bench_merge.parse(doc)


class ShippedBenchmarksTest(unittest.TestCase):
    def setUp(self):
        with open(os.path.join(PKG, "BENCHMARKS.md")) as f:
            self.doc = f.read()
        self.items = bench_merge.parse(self.doc)
        self.blocks = [it for it in self.items if not isinstance(it, str)]

    def test_every_benchmark_script_has_its_blocks(self):
        scripts = {os.path.relpath(p, PKG) for p in glob.glob(os.path.join(PKG, "scripts/bench/*.sh"))}
        with_blocks = {b[0] for b in self.blocks}
        self.assertEqual(scripts - with_blocks, set(), "no block: make bench would append them")
        for script in with_blocks:
            self.assertTrue(os.path.exists(os.path.join(PKG, script)), script)

    def test_each_block_starts_with_its_heading(self):
        for script, heading, text in self.blocks:
            first = text.split("\n", 1)[0]
            if heading:
                self.assertRegex(first, r"^#+ " + heading.replace("?", r"\?") + "$", script)
            else:
                self.assertFalse(first.startswith("#"), script)

    def test_its_own_blocks_merged_back_change_nothing(self):
        outputs = {}
        for script, _, text in self.blocks:
            outputs[script] = outputs.get(script, "") + text + "\n\n"
        topics = [("", sorted(outputs))]
        self.assertEqual(bench_merge.merge(self.doc, topics, outputs), self.doc)


if __name__ == "__main__":
    junit_result.main("test_bench_merge")
