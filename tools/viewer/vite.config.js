import { defineConfig } from 'vite';

// base './': dist/ works from any directory of a static server (python3 -m http.server).
export default defineConfig({
  base: './',
  build: { outDir: 'dist', emptyOutDir: true, chunkSizeWarningLimit: 1000 },
  test: { environment: 'node', include: ['tests/**/*.test.js'] },
});
