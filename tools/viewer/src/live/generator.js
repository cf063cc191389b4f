// The built-in text-conditioned motion generator (include/maskadapt/tracking/builtin_generator.hpp)
// read from its checkpoint (models/text_generator.bin) and run as the C++ runs generate():
//
//   h  = normalise(encode_frames(history))                  (H·D; frameFeatures.js)
//   φ  = hashed text features of the prompt (K; zeros for a prompt without words = unconditional)
//   e  = P φ + b                                            (denoiser.projection, E)
//   x_{T−1} ~ N(0, I) (L); for t = T−1 … 0:
//     x̂₀ = w·f(x_t, t, e, h) + (1 − w)·f(x_t, t, 0, h)       (denoiser.net on [x_t ; τ(t) ; e ; h], w = guidance)
//     x_{t−1} = c1_t x̂₀ + c2_t x_t + √β̃_t z   (no noise at t = 0)
//   future = denormalise(decoder([h ; latent_scale · x]))  → F frames (canonical frame; decodeFrames)
//
// The normal variates come from a noise source with a normal() method: the library's Rng (rng.js,
// the same numbers as the C++ for the same seed) or recorded values (ReplayNormals). Every problem
// with the file throws an Error naming the file and the section.
import { CheckpointError, getFloat32, getScalarDouble, getString, has, parseCheckpoint } from './checkpoint.js';
import { cosineSchedule, guidedPrediction, posteriorMean, timestepEmbedding } from './diffusion.js';
import { decodeFrames, encodeFrames, frameLayout } from './frameFeatures.js';
import { computeBodyPositions } from './kinematics.js';
import { Mlp, numMlpParams } from './mlp.js';
import { hashedTextFeatures } from './textFeatures.js';

export const GENERATOR_FORMAT = 'maskadapt.builtin_generator.v1';

const now = () => (typeof performance !== 'undefined' ? performance.now() : Date.now());

export class Generator {
  /**
   * @param buffer the checkpoint bytes; `file` labels errors
   * @param skel   the skeleton it must have been trained on (kinematics.js makeSkeleton), checked by body names
   */
  constructor(buffer, file, skel) {
    const ck = parseCheckpoint(buffer, file);
    const err = (field, msg) => new CheckpointError(file, field, msg);
    if (!has(ck, 'generator.format')) throw err('generator.format', 'missing section: not a built-in generator checkpoint (models/text_generator.bin)');
    const format = getString(ck, 'generator.format');
    if (format !== GENERATOR_FORMAT) throw err('generator.format', `'${format}': not a built-in generator checkpoint (expected '${GENERATOR_FORMAT}')`);
    let c;
    try {
      c = JSON.parse(getString(ck, 'generator.config'));
    } catch (e) {
      if (e instanceof CheckpointError) throw e;
      throw err('generator.config', `not valid JSON: ${e.message}`);
    }
    const int = (key, min = 1) => {
      if (!Number.isInteger(c[key]) || c[key] < min) throw err('generator.config', `field '${key}' must be an integer >= ${min}, got ${JSON.stringify(c[key])}`);
      return c[key];
    };
    const list = (key) => {
      if (!Array.isArray(c[key]) || c[key].some((h) => !Number.isInteger(h) || h <= 0)) throw err('generator.config', `field '${key}' must be a list of positive integers`);
      return c[key];
    };
    this.H = int('history');
    this.F = int('future');
    this.L = int('latent');
    this.K = int('text_features', 8);
    this.E = int('text_embed');
    this.timeEmbed = int('time_embed', 2);
    if (this.timeEmbed % 2) throw err('generator.config', `field 'time_embed' must be even, got ${this.timeEmbed}`);
    this.T = int('diffusion_steps');
    if (!Number.isFinite(c.guidance)) throw err('generator.config', `field 'guidance' must be a number`);
    this.guidance = c.guidance;
    this.temperature = c.temperature === undefined ? 1 : c.temperature;
    if (!(this.temperature > 0 && this.temperature <= 1)) throw err('generator.config.temperature', `temperature must lie in (0, 1], got ${this.temperature}`);
    if (!Array.isArray(c.bodies) || c.bodies.length !== skel.nb || c.bodies.some((n, i) => n !== skel.names[i]))
      throw err('generator.config.bodies', `this generator was trained on another skeleton (bodies ${JSON.stringify(c.bodies)})`);
    this.skel = skel;
    this.D = frameLayout(skel).dim;
    const HD = this.H * this.D, FD = this.F * this.D;
    const sizes = {
      encoder: [HD + FD, ...list('vae_hidden'), 2 * this.L],
      decoder: [HD + this.L, ...list('vae_hidden'), FD],
      projection: [this.K, this.E],
      net: [this.L + this.timeEmbed + this.E + HD, ...list('denoiser_hidden'), this.L],
    };
    const params = (name, n) => {
      const s = ck.sections.get(name);
      if (!s) throw err(name, 'missing section');
      if (s.dtype !== 'float32') throw err(name, `dtype mismatch: expected float32, found ${s.dtype}`);
      if (s.numel !== n) throw err(name, `has ${s.numel} values, the config's architecture needs ${n}`);
      const v = getFloat32(ck, name);
      for (let i = 0; i < v.length; ++i) if (!Number.isFinite(v[i])) throw err(name, `value ${i} is not finite`);
      return v;
    };
    // (the encoder is not needed to generate; its size is still checked)
    const enc = ck.sections.get('vae.encoder');
    if (!enc) throw err('vae.encoder', 'missing section');
    if (enc.numel !== numMlpParams(sizes.encoder)) throw err('vae.encoder', `has ${enc.numel} values, the config's architecture needs ${numMlpParams(sizes.encoder)}`);
    const wrap = (name, sz, act) => {
      try {
        return new Mlp(params(name, numMlpParams(sz)), sz, act, name);
      } catch (e) {
        if (e instanceof CheckpointError) throw e;
        throw err(name, e.message);
      }
    };
    this.decoder = wrap('vae.decoder', sizes.decoder, c.vae_activation);
    this.projection = wrap('denoiser.projection', sizes.projection, 'identity');
    this.net = wrap('denoiser.net', sizes.net, c.denoiser_activation);
    this.historyMean = params('vae.history_mean', HD);
    this.historyStd = params('vae.history_std', HD);
    this.futureMean = params('vae.future_mean', FD);
    this.futureStd = params('vae.future_std', FD);
    for (const [name, v] of [['vae.history_std', this.historyStd], ['vae.future_std', this.futureStd]])
      for (let i = 0; i < v.length; ++i) if (!(v[i] > 0)) throw err(name, `entry ${i} is not positive (${v[i]})`);
    const scale = getScalarDouble(ck, 'latent_scale');
    if (!(Number.isFinite(scale) && scale > 0)) throw err('latent_scale', `must be positive, got ${scale}`);
    this.latentScale = Math.fround(scale);
    this.armsPool = [];
    if (has(ck, 'generator.arms_pool')) {
      try {
        this.armsPool = JSON.parse(getString(ck, 'generator.arms_pool'));
      } catch (e) {
        throw err('generator.arms_pool', `not valid JSON: ${e.message}`);
      }
      if (!Array.isArray(this.armsPool) || this.armsPool.some((s) => typeof s !== 'string')) throw err('generator.arms_pool', 'must be a list of prompts');
    }
    this.schedule = cosineSchedule(this.T);
    this.file = file;
    this.calls = 0;
    this.totalMs = 0;
    this.lastMs = 0;
  }

  get description() {
    return `text generator: VAE (H ${this.H}, F ${this.F}, latent ${this.L}) + latent DDPM (${this.T} steps, guidance ${this.guidance})`;
  }

  /** Hashed text features of a prompt (K). */
  textFeatures(text) {
    return hashedTextFeatures(text, this.K);
  }

  /** Normalised history features (Float32Array, H·D) of a canonical history (H frames). */
  normalisedHistory(history, trace = null) {
    if (history.frames !== this.H) throw new Error(`history must have H = ${this.H} frames, got ${history.frames}`);
    const h = { ...history, bodyPos: new Float64Array(3 * this.skel.nb * history.frames) };
    computeBodyPositions(this.skel, h);
    const hf = encodeFrames(this.skel, h);
    const hn = new Float32Array(hf.length);
    for (let i = 0; i < hf.length; ++i) hn[i] = Math.fround(Math.fround(hf[i] - this.historyMean[i]) / this.historyStd[i]);
    if (trace) Object.assign(trace, { history: h, historyFeatures: hf, historyNormalised: hn });
    return hn;
  }

  /**
   * What stays fixed over the T denoising steps of one sample: the text embedding e = P φ + b (E),
   * whether the prompt is unconditional (all-zero features), and the first layer's partial sums
   * over the history and over e (the C++ computes them once per sample too).
   */
  denoiserContext(tf, hn) {
    const { L, E, timeEmbed } = this;
    const embedding = this.projection.forward(tf);
    let unconditional = true;
    for (let i = 0; i < tf.length; ++i) if (tf[i] !== 0) unconditional = false;
    const hOff = L + timeEmbed + E;
    return {
      embedding,
      unconditional,
      partialHistory: this.net.firstLayerPartial(hn, hOff, hOff + hn.length),
      partialText: this.net.firstLayerPartial(embedding, L + timeEmbed, hOff),
      input: new Float32Array(L + timeEmbed), // [x_t ; τ(t)], reused
    };
  }

  /**
   * One denoiser call: x̂₀ for latent x_t (L) at step t, { cond, uncond, x0 } (uncond null when
   * the prompt is unconditional or the guidance is 1; x0 = w·cond + (1 − w)·uncond).
   */
  predictX0(ctx, x, t) {
    const { L, timeEmbed } = this;
    const w = this.guidance;
    ctx.input.set(x, 0);
    ctx.input.set(timestepEmbedding(t, timeEmbed), L);
    const partials = ctx.unconditional ? [ctx.partialHistory] : [ctx.partialHistory, ctx.partialText];
    const cond = this.net.forward(ctx.input, new Float32Array(L), partials, L + timeEmbed);
    if (ctx.unconditional || w === 1) return { cond, uncond: null, x0: cond };
    const uncond = this.net.forward(ctx.input, new Float32Array(L), [ctx.partialHistory], L + timeEmbed);
    return { cond, uncond, x0: guidedPrediction(cond, uncond, w) };
  }

  /** σ of the noise added after step t > 0: √(posterior variance), times the temperature τ (float). */
  noiseScale(t) {
    const sd = Math.sqrt(this.schedule.posteriorVariance[t]);
    return Math.fround(this.temperature === 1 ? sd : Math.fround(this.temperature) * Math.fround(sd));
  }

  /** x_{t−1}: the posterior mean of x̂₀ and x_t, plus noiseScale(t)·z for t > 0 (z: L normals, null at t = 0). */
  previousLatent(t, x0, xt, z) {
    const next = posteriorMean(this.schedule, t, x0, xt);
    if (z) {
      const sigma = this.noiseScale(t);
      for (let i = 0; i < next.length; ++i) next[i] = Math.fround(next[i] + Math.fround(sigma * z[i]));
    }
    return next;
  }

  /**
   * Latent (L) for normalised history hn and text features tf: guided DDPM with normals from
   * `noise`, times latent_scale. `trace` (optional) receives every intermediate.
   */
  sampleLatent(tf, hn, noise, trace = null) {
    const { L } = this;
    const ctx = this.denoiserContext(tf, hn);
    const tau = Math.fround(this.temperature);
    let x = new Float32Array(L);
    for (let i = 0; i < L; ++i) x[i] = this.temperature === 1 ? Math.fround(noise.normal()) : Math.fround(tau * Math.fround(noise.normal()));
    const steps = [];
    if (trace) Object.assign(trace, { textFeatures: tf, embedding: ctx.embedding, unconditional: ctx.unconditional, initialNoise: x.slice(), steps });
    const s = this.schedule;
    for (let t = s.numSteps - 1; t >= 0; --t) {
      const p = this.predictX0(ctx, x, t);
      for (let i = 0; i < L; ++i) if (!Number.isFinite(p.x0[i])) throw new Error(`generator: the denoiser's x0_hat is not finite at step ${t}`);
      let z = null;
      if (t > 0) {
        z = new Float32Array(L);
        for (let i = 0; i < L; ++i) z[i] = Math.fround(noise.normal());
      }
      const next = this.previousLatent(t, p.x0, x, z);
      if (trace) steps.push({ t, xt: x, cond: p.cond, uncond: p.uncond, x0: p.x0, noise: z, next });
      x = next;
    }
    const latent = new Float32Array(L);
    for (let i = 0; i < L; ++i) latent[i] = Math.fround(this.latentScale * x[i]);
    if (trace) trace.latent = latent;
    return latent;
  }

  /** F future frames (canonical frame) after a canonical history of H frames, for a prompt. */
  generate(text, history, noise, trace = null) {
    const t0 = now();
    const hn = this.normalisedHistory(history, trace);
    const tf = typeof text === 'string' ? this.textFeatures(text) : text;
    if (tf.length !== this.K) throw new Error(`text features have ${tf.length} values, the generator expects ${this.K}`);
    const z = this.sampleLatent(tf, hn, noise, trace);
    const x = new Float32Array(hn.length + z.length);
    x.set(hn, 0);
    x.set(z, hn.length);
    const dec = this.decoder.forward(x);
    const fut = new Float32Array(dec.length);
    for (let i = 0; i < dec.length; ++i) fut[i] = Math.fround(Math.fround(dec[i] * this.futureStd[i]) + this.futureMean[i]);
    const out = decodeFrames(this.skel, fut, this.F, history.fps);
    if (trace) Object.assign(trace, { decodedNormalised: dec, futureFeatures: fut });
    this.lastMs = now() - t0;
    this.totalMs += this.lastMs;
    ++this.calls;
    return out;
  }
}

/** Loads a generator file (ArrayBuffer / Uint8Array). */
export function loadGenerator(buffer, file, skel) {
  return new Generator(buffer, file, skel);
}
