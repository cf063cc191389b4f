// A plain MLP in float (include/maskadapt/nn/mlp.hpp: all parameters in one flat vector, layer
// after layer W_l (out × in, column-major) then b_l; y = W_L σ(… σ(W_1 x + b_1) …) + b_L with the
// activation of nn/activation.hpp). Products are summed in double and rounded to float per
// output (the C++ sums in float in another order: they agree to ~1e-7 relative).

export const ACTIVATIONS = {
  relu: (z) => (z > 0 ? z : 0),
  elu: (z) => (z > 0 ? z : Math.expm1(z)),
  silu: (z) => z / (1 + Math.exp(-z)),
  tanh: Math.tanh,
  identity: (z) => z,
};

export function numMlpParams(sizes) {
  let n = 0;
  for (let l = 0; l + 1 < sizes.length; ++l) n += sizes[l + 1] * (sizes[l] + 1);
  return n;
}

export class Mlp {
  /** @param params Float32Array (numMlpParams(sizes)); sizes [in, hidden…, out]; activation name. */
  constructor(params, sizes, activation, what = 'mlp') {
    const act = ACTIVATIONS[activation];
    if (!act) throw new Error(`${what}: unknown activation '${activation}'`);
    const n = numMlpParams(sizes);
    if (params.length !== n) throw new Error(`${what}: has ${params.length} parameters, the architecture [${sizes.join(', ')}] has ${n}`);
    this.act = act;
    this.sizes = sizes;
    this.layers = [];
    let off = 0;
    for (let l = 0; l + 1 < sizes.length; ++l) {
      const nin = sizes[l], nout = sizes[l + 1];
      this.layers.push({ nin, nout, W: params.subarray(off, off + nout * nin), b: params.subarray(off + nout * nin, off + nout * (nin + 1)) });
      off += nout * (nin + 1);
    }
    this.inputDim = sizes[0];
    this.outputDim = sizes[sizes.length - 1];
  }

  /**
   * Pre-activation of the first layer restricted to input rows [from, to): W_1[:, from:to] · x
   * (Float64Array of the first layer's outputs, no bias). Lets a caller sum constant parts of the
   * input once (the generator's history rows are the same for all 20 denoiser calls).
   */
  firstLayerPartial(x, from, to, out = new Float64Array(this.layers[0].nout)) {
    const { nout, W } = this.layers[0];
    out.fill(0);
    for (let i = from; i < to; ++i) {
      const xi = x[i - from];
      if (xi === 0) continue;
      const col = W.subarray(i * nout, (i + 1) * nout);
      for (let o = 0; o < nout; ++o) out[o] += col[o] * xi;
    }
    return out;
  }

  /**
   * Forward pass. `x` (Float32Array, inputDim) — or, with `partials` (an array of Float64Array
   * from firstLayerPartial) only the rows [0, rows) of x, the rest being summed in the partials.
   */
  forward(x, out = new Float32Array(this.outputDim), partials = null, rows = x.length) {
    let input = x;
    for (let l = 0; l < this.layers.length; ++l) {
      const { nin, nout, W, b } = this.layers[l];
      const last = l + 1 === this.layers.length;
      const dst = last ? out : new Float32Array(nout);
      const acc = new Float64Array(nout);
      const upto = l === 0 && partials ? rows : nin;
      if (l === 0 && partials) for (const p of partials) for (let o = 0; o < nout; ++o) acc[o] += p[o];
      for (let i = 0; i < upto; ++i) {
        const xi = input[i];
        if (xi === 0) continue;
        const col = W.subarray(i * nout, (i + 1) * nout);
        for (let o = 0; o < nout; ++o) acc[o] += col[o] * xi;
      }
      for (let o = 0; o < nout; ++o) {
        const z = Math.fround(acc[o] + b[o]);
        dst[o] = last ? z : Math.fround(this.act(z));
      }
      input = dst;
    }
    return out;
  }
}
