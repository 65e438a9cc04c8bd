"""scikit-learn's Gaussian process on the points `kriging_scale` wrote: prints its
held-out RMSE, log marginal likelihood and fit seconds (median of 3).

Usage: python3 sklearn_reference.py DIR {se|matern52}
DIR holds x.csv (points), y.csv (responses), t.csv (test points), u.csv (their truth).
"""

import sys
import time

import numpy as np
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, Matern, WhiteKernel

folder, kernel_name = sys.argv[1], sys.argv[2]
x = np.loadtxt(f"{folder}/x.csv", delimiter=",", ndmin=2)
y = np.loadtxt(f"{folder}/y.csv", delimiter=",")
t = np.loadtxt(f"{folder}/t.csv", delimiter=",", ndmin=2)
u = np.loadtxt(f"{folder}/u.csv", delimiter=",")
k = x.shape[1]
if kernel_name == "se":
    shape = RBF(length_scale=np.ones(k), length_scale_bounds=(1e-2, 1e2))
else:
    shape = Matern(length_scale=np.ones(k), length_scale_bounds=(1e-2, 1e2), nu=2.5)
kernel = ConstantKernel(1.0, (1e-3, 1e3)) * shape + WhiteKernel(1e-6, (1e-12, 1e-1))

times = []
for _ in range(3):
    model = GaussianProcessRegressor(
        kernel=kernel, normalize_y=True, n_restarts_optimizer=7, random_state=0
    )
    start = time.perf_counter()
    model.fit(x, y)
    times.append(time.perf_counter() - start)
times.sort()
rmse = float(np.sqrt(np.mean((model.predict(t) - u) ** 2)))
# scikit-learn's likelihood is of the normalised responses; in response units it is
# lower by n ln(std(y)) (scikit-learn's std, without Bessel's correction).
loglik = model.log_marginal_likelihood_value_ - len(y) * np.log(np.std(y))
print(rmse, loglik, times[1])
