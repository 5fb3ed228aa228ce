pub use savme_kernel as kernel;
