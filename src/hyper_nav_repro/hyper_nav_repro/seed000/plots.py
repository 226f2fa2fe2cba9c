"""PNGs of the seed 000 RL-DLAC reproduction (``seed000.reproduce``)."""
from __future__ import annotations

import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def write_plots(result: dict, out_dir: pathlib.Path) -> list[pathlib.Path]:
    out = []
    if result.get("table5") and result.get("compare"):
        out += [_rewards(result, out_dir / "reward_per_episode.png"),
                _frequencies(result, out_dir / "frequency_estimates.png")]
    if result.get("navigation"):
        out.append(_navigation(result["navigation"], out_dir / "navigation_errors.png"))
    if result.get("surface"):
        out.append(_surface(result["surface"], out_dir / "reward_surface.png"))
    if result.get("identifier"):
        out.append(_identifier(result["identifier"], out_dir / "identifier_error_over_sigma.png"))
    return out


def _identifier(ident, path):
    """Part 6: maximum likelihood's error / its reported sigma per window
    (converged: filled; not: open), per frequency and true set, with the +-3
    band; DDPG's error in the same sigma units beside it (clipped)."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    sets = list(ident["by_set"])
    for ax, who in zip(axes, ("max_likelihood", "ddpg")):
        for j, name in enumerate(sets):
            rs = [r for r in ident["runs"] if r["set"] == name]
            for i in range(3):
                key = "error_over_sigma" if who == "max_likelihood" else "error_over_ml_sigma"
                z = np.clip([r[who][key][i] for r in rs], -50.0, 50.0)
                x = i + 0.25 * (j - 1) + np.linspace(-0.05, 0.05, len(z))
                conv = [r["max_likelihood"]["converged"] for r in rs]
                ax.scatter(x, z, s=12, color=f"C{j}", facecolors=[f"C{j}" if c else "none" for c in conv],
                           label=name if i == 0 else None)
        ax.axhspan(-3.0, 3.0, color="0.9", zorder=0)
        ax.set_xticks([0, 1, 2], ["w1", "w2", "w3"])
        ax.set_ylabel("error / ML reported sigma" + (" (clipped at +-50)" if who == "ddpg" else ""))
        ax.set_title(("maximum likelihood" if who == "max_likelihood" else "DDPG (Table 3), same windows")
                     + f"\n{ident['data']}", fontsize=7)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _rewards(result, path):
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    cases = [("paper flight (Table 5 windows)", [r for r in result["table5"]["runs"]]),
             ("excited, model-consistent data", result["compare"]["excited"]["runs"]["ddpg"])]
    for ax, (title, runs) in zip(axes, cases):
        for r in runs:
            ep = r.get("episode_rewards_m")
            if ep is None:
                src = [x for x in result["table5"]["runs"] if x["seed"] == r["seed"]]
                ep = src[0]["episode_rewards_m"] if src else []
            if len(ep):
                ax.plot(np.arange(1, len(ep) + 1), ep, lw=0.8, label=f"seed {r['seed']}")
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("episode")
        ax.set_ylabel("reward per episode (sum of 5 steps) [m]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=6, ncol=2)
    fig.suptitle("DDPG reward per episode (reward = -RMS position residual over the window)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _frequencies(result, path):
    paper = result["paper"]
    fig, axes = plt.subplots(1, 3, figsize=(12, 4))
    methods = ("ddpg", "cmaes", "nelder_mead", "max_likelihood")
    for i, ax in enumerate(axes):
        x = 0
        ticks, labels = [], []
        for case in ("paper", "excited"):
            rows = result["compare"][case]["runs"]
            for m in methods:
                vals = [r["freqs_radps"][i] for r in rows[m]]
                if case == "paper" and m == "ddpg":
                    vals = [r["learned_radps"][i] for r in result["table5"]["runs"]]
                ax.plot([x] * len(vals), vals, "o", ms=4, alpha=0.7)
                ticks.append(x)
                labels.append(f"{case}\n{m}")
                x += 1
        ax.axhline(paper["true_radps"][i], color="g", lw=1, label="true (Table 4)")
        ax.axhline(paper["initial_radps"][i], color="k", ls=":", lw=1, label="initial (Table 2)")
        ax.axhline(paper["learned_radps"][i], color="r", ls="--", lw=1, label="paper learned (Table 5)")
        ax.set_xticks(ticks)
        ax.set_xticklabels(labels, fontsize=6, rotation=90)
        ax.set_ylabel(f"w{i + 1} [rad/s]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle("Frequency estimates per method and seed")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _navigation(nav, path):
    fig, axes = plt.subplots(3, 1, figsize=(10, 9), sharex=True)
    for name, run in nav["runs"].items():
        t = np.asarray(run["t_s"])
        for ax, key, unit in zip(axes, ("pos", "vel", "att"), ("m", "m/s", "deg")):
            e = np.linalg.norm(np.asarray(run[key]), axis=1)
            ax.plot(t, e, lw=0.7, label=f"{name} (RMS {run['rms_3d'][key]:.4g} {unit})")
            ax.set_ylabel(f"|{key} error| [{unit}]")
    if nav.get("t_update_s") is not None:
        for ax in axes:
            ax.axvline(nav["t_update_s"], color="k", ls=":", lw=0.8)
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    axes[-1].set_xlabel("t [s]")
    fig.suptitle("Navigation errors, KF-FLAC vs RL-DLAC (seed 000 Figs. 10-11); dotted: model update")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _surface(surface, path):
    f = np.asarray(surface["fractions"])
    fig, axes = plt.subplots(2, 3, figsize=(12, 6))
    for i in range(3):
        cases = (("noisy", "-", "paper flight"), ("mean", "--", "paper flight, mean data"),
                 ("excited_simulated", ":", "doublet flight"))
        for label, ls, text in [x for x in cases if x[0] in surface]:
            row = surface[label][f"w{i + 1}"]
            r = np.asarray(row["reward_m"])
            n = np.asarray(row["nll"])
            axes[0, i].plot(f, 1e3 * (r - r.max()), ls, marker="o", ms=3, label=text)
            axes[1, i].plot(f, n - n.min(), ls, marker="o", ms=3, label=text)
            axes[1, i].set_yscale("symlog", linthresh=1.0)
        axes[0, i].set_title(f"w{i + 1} x fraction (others true)", fontsize=9)
        axes[0, i].set_ylabel("reward - max [mm]")
        axes[1, i].set_ylabel("-log likelihood - min")
        axes[1, i].axhline(0.5, color="r", lw=0.7, ls=":")
        for ax in axes[:, i]:
            ax.grid(alpha=0.3)
            ax.set_xlabel("w / w_true")
    axes[0, 0].legend(fontsize=7)
    fig.suptitle("Reward surface around the truth (dotted: 0.5, the 1-sigma level of -log L)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
