# Sourced by the results scripts (bash). default_runs DIR [MAX]: the run directories in DIR (one
# method's runs, e.g. outputs/results/real/ycbv-gt_model/ours) made with the method's default
# settings (no method.* override), newest first; of runs with the same overrides (an older
# default's run beside today's) only the newest; at most MAX of them.
default_runs() {
  local d key seen="" n=0
  for d in $(ls -dt "$1"/*/ 2>/dev/null); do
    [ -f "$d/overrides.txt" ] && ! grep -q '^method\.' "$d/overrides.txt" || continue
    key=$(md5sum < "$d/overrides.txt" | cut -c1-12)
    case " $seen " in *" $key "*) continue ;; esac
    seen="$seen $key"; echo "${d%/}"; n=$((n + 1))
    if [ -n "${2:-}" ] && [ "$n" -ge "$2" ]; then break; fi
  done
  return 0
}
