#!/usr/bin/python3
"""Reference values of the binomial upper tail for tests/test_culling_math.cpp (Eq. 21 of
Ibrahim et al. 2021): reads JSON [[N, k, p], ...] on stdin, writes JSON [P(X >= k), ...] with
X ~ Binomial(N, p), computed by scipy.stats.binom.sf(k - 1, N, p) at test time."""
import json
import sys

from scipy.stats import binom

queries = json.load(sys.stdin)
out = [float(binom.sf(k - 1, n, p)) for n, k, p in queries]
json.dump(out, sys.stdout)
