"""JUnit XML for the Python checks, so that scripts/test.sh counts their
cases beside gtest's and rostest's."""
import os
from xml.sax.saxutils import quoteattr


def write_suite(results_dir, suite, cases):
    """Writes RESULTS_DIR/SUITE.xml: one test case per (name, failure) in
    `cases`, failure a message or None (passed)."""
    os.makedirs(results_dir, exist_ok=True)
    with open(os.path.join(results_dir, suite + ".xml"), "w") as f:
        f.write('<?xml version="1.0"?>\n<testsuite name=%s tests="%d" failures="%d">\n'
                % (quoteattr(suite), len(cases), sum(1 for _, failure in cases if failure)))
        for name, failure in cases:
            body = "<failure message=%s/>" % quoteattr(failure) if failure else ""
            f.write("<testcase classname=%s name=%s>%s</testcase>\n"
                    % (quoteattr(suite), quoteattr(name), body))
        f.write("</testsuite>\n")
