"""Whether a process still runs, as a test that waits for it to end asks."""


def running(pid):
    """Whether process ``pid`` runs (neither gone nor a zombie waiting to be reaped)."""
    try:
        with open(f'/proc/{pid}/stat') as stat:
            return stat.read().split(')')[-1].split()[0] != 'Z'
    except FileNotFoundError:
        return False
