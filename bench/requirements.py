"""The PASS/FAIL lines the bench scripts end with: one line per requirement, value against its bar."""


class Requirements:
    """req = Requirements('issue 13'); req('B1 flips', flips, 0); ...; req.ok is False if any failed."""

    def __init__(self, title):
        print(f'requirements ({title}):')
        self.ok = True

    def __call__(self, name, value, limit):
        good = value == value and value <= limit  # NaN (a missing figure) fails
        self.ok &= good
        print(f'  {"PASS" if good else "FAIL"}  {name}: {value:.4g} (<= {limit})')
        return good
