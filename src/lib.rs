pub use foosball_env as env;
