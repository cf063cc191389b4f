// DDPM pieces of include/maskadapt/tracking/diffusion.hpp: the cosine noise schedule (Nichol &
// Dhariwal, s = 0.008, β ≤ 0.999) and its derived coefficients in double, the sinusoidal step
// embedding, the posterior mean c1_t·x̂₀ + c2_t·x_t and classifier-free guidance w·cond + (1 − w)·uncond
// in float, as the C++ evaluates them.

export function cosineSchedule(T, s = 0.008, maxBeta = 0.999) {
  if (!(Number.isInteger(T) && T >= 1)) throw new Error(`number of diffusion steps must be an integer >= 1, got ${T}`);
  const f = (t) => {
    const c = Math.cos(((t / T + s) / (1 + s)) * (Math.PI / 2));
    return c * c;
  };
  const betas = [];
  for (let t = 0; t < T; ++t) betas.push(Math.min(1 - f(t + 1) / f(t), maxBeta));
  return scheduleFromBetas(betas);
}

export function scheduleFromBetas(betas) {
  const T = betas.length;
  const alphas = betas.map((b) => 1 - b);
  const alphaBars = [], alphaBarsPrev = [];
  let prod = 1;
  for (let t = 0; t < T; ++t) {
    alphaBarsPrev.push(prod);
    prod *= alphas[t];
    alphaBars.push(prod);
  }
  const posteriorVariance = [], coefX0 = [], coefXt = [];
  for (let t = 0; t < T; ++t) {
    const omab = 1 - alphaBars[t];
    posteriorVariance.push((betas[t] * (1 - alphaBarsPrev[t])) / omab);
    coefX0.push((Math.sqrt(alphaBarsPrev[t]) * betas[t]) / omab);
    coefXt.push((Math.sqrt(alphas[t]) * (1 - alphaBarsPrev[t])) / omab);
  }
  return { numSteps: T, betas, alphas, alphaBars, alphaBarsPrev, posteriorVariance, coefX0, coefXt };
}

/** [sin(t·ω_k), cos(t·ω_k)], ω_k = 10000^(−k/half) (Float32Array of dim). */
export function timestepEmbedding(t, dim) {
  if (!(dim >= 2 && dim % 2 === 0)) throw new Error(`timestep embedding dimension must be even and >= 2, got ${dim}`);
  const e = new Float32Array(dim);
  const half = dim / 2;
  for (let k = 0; k < half; ++k) {
    const w = Math.pow(10000, -k / half);
    e[k] = Math.sin(t * w);
    e[half + k] = Math.cos(t * w);
  }
  return e;
}

/** μ̃_t = c1_t x̂₀ + c2_t x_t (float). */
export function posteriorMean(s, t, x0, xt, out = new Float32Array(x0.length)) {
  const c1 = Math.fround(s.coefX0[t]), c2 = Math.fround(s.coefXt[t]);
  for (let i = 0; i < x0.length; ++i) out[i] = Math.fround(Math.fround(c1 * x0[i]) + Math.fround(c2 * xt[i]));
  return out;
}

/** w·cond + (1 − w)·uncond (float). */
export function guidedPrediction(cond, uncond, w, out = new Float32Array(cond.length)) {
  const a = Math.fround(w), b = Math.fround(1 - w);
  for (let i = 0; i < cond.length; ++i) out[i] = Math.fround(Math.fround(a * cond[i]) + Math.fround(b * uncond[i]));
  return out;
}
